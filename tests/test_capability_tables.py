"""The capability tables of the docs against the declarations they describe.

docs/architecture.md lists every predictor capability (``predictors.base.Capability``) with its
protocol and the members it adds to the core; docs/trackers.md lists what every registered
predictor and agent declares. Each table is parsed from the page and compared with the enums,
their protocols and the registries, so a capability or a plug-in added in the code and not in the
docs (or the reverse) fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

from agents.base import AGENT_DECLARATIONS, AGENTS
from predictors import make_predictor
from predictors.base import DECLARATIONS, Capability
from predictors.registry import PREDICTORS

DOCS = Path(__file__).resolve().parents[1] / "docs"


def table(page: str, header: str) -> list[list[str]]:
    """The body rows of the Markdown table on ``page`` whose header row starts with ``header``,
    as lists of cell texts."""
    lines = (DOCS / page).read_text(encoding="utf-8").splitlines()
    start = next(
        i
        for i, line in enumerate(lines[:-1])
        if line.startswith(f"| {header} |") and lines[i + 1].startswith("|---")
    )
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def names(cell: str) -> list[str]:
    """The code spans of a cell, without the call syntax (``reset(spec, *, rng=)`` -> ``reset``);
    ``none`` is no name."""
    return [re.sub(r"\(.*", "", code) for code in re.findall(r"`([^`]+)`", cell)]


def protocol_members(protocol: type) -> set[str]:
    """The members a capability's protocol adds to the core (what a declaring class must have),
    plus a core method it redefines with extra keywords."""
    own = vars(protocol)
    methods = {n for n, v in own.items() if callable(v) and not n.startswith("_")}
    return methods | set(own.get("__annotations__", {}))


def test_architecture_lists_every_predictor_capability_with_its_protocol():
    rows = table("architecture.md", "capability")
    documented = {names(row[0])[0]: row for row in rows}
    assert sorted(documented) == sorted(c.name for c in Capability)
    for capability, protocol in DECLARATIONS.protocols.items():
        row = documented[capability.name]
        assert names(row[1]) == [protocol.__name__], capability
        assert set(names(row[2])) == protocol_members(protocol), capability


def test_trackers_page_lists_what_every_predictor_declares():
    rows = table("trackers.md", "predictor")
    documented = {names(row[0])[0]: row for row in rows}
    assert sorted(documented) == PREDICTORS.names()
    for name, row in documented.items():
        predictor = make_predictor(name)
        assert names(row[1]) == [type(predictor).__name__], name
        assert set(names(row[2])) == {c.name for c in DECLARATIONS.declared(predictor)}, name


def test_trackers_page_lists_what_every_agent_declares():
    rows = table("trackers.md", "agent")
    documented = {names(row[0])[0]: row for row in rows}
    assert sorted(documented) == AGENTS.names()
    for name, row in documented.items():
        factory = AGENTS.factory(name)
        assert names(row[1]) == [factory.__name__], name
        declared = {c.name for c in AGENT_DECLARATIONS.declared(factory)}
        assert set(names(row[2])) == declared, name
        assert (row[2] == "none") == (not declared), name
