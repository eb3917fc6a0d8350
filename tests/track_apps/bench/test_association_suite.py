"""The association suite (track_apps/bench/suites/association.toml): its cells, pinned.

The digest is that of the ordered cell keys when the suite was written; a change of a key (a
kwarg, a seed, the order) changes the record files of a run and shows here. Where no ``jpda``
agent is registered, a stand-in with its assumed signature (gnn's, plus ``merge_model``) is, so
that the suite expands; the keys depend on the cells alone, not on the agent behind the name.
"""

from __future__ import annotations

import hashlib
from collections import Counter
from typing import Any

import pytest

from agents import AGENTS
from agents.gnn.agent import GnnAgent
from track_apps.bench.cells import expand, load_suite

#: (cells, sha256 of the comma-joined ordered keys) of the suite and of its quick variant.
DIGESTS = {
    False: (840, "d9f720d995aecd63e6efe8025e3c05ec3ef9cb99045e36a71dddc165236ebcd7"),
    True: (224, "8ce0e5fd6b1ceb409ba15db6ae9a39172faad81d0ea2cd56de2ea19de3335ee9"),
}
PREDICTORS = {"kf-cv", "kf-ca", "lstm", "nll-lstm", "mc-lstm"}


class StandInJpda(GnnAgent):
    """The gnn under the name ``jpda``, with a ``merge_model`` switch that does nothing."""

    def __init__(self, predictor: Any = "kf-ca", *, merge_model: bool = True, **kwargs: Any):
        super().__init__(predictor, **kwargs)
        self.merge_model = merge_model


@pytest.fixture
def jpda(monkeypatch: pytest.MonkeyPatch) -> None:
    """Register the stand-in as ``jpda`` for the test where no ``jpda`` agent is registered."""
    if "jpda" not in AGENTS.names():
        monkeypatch.setitem(AGENTS._factories, "jpda", StandInJpda)


@pytest.mark.parametrize("quick", [False, True])
def test_the_association_suite_expands_to_its_pinned_cells(jpda, quick):
    keys = [c.key for c in expand(load_suite("association", quick=quick))]
    assert (len(keys), hashlib.sha256(",".join(keys).encode()).hexdigest()) == DIGESTS[quick]


def _contestant(cell: Any) -> tuple[str, bool, str]:
    kw = dict(cell.agent_kwargs)
    merge = kw.get("merge_model", True) if cell.agent == "jpda" else kw.get("blob_extent", 0.0) > 0
    return cell.agent, merge, cell.predictor


def test_every_contestant_runs_every_setting_and_seed_of_full_episodes(jpda):
    cells = expand(load_suite("association"))
    assert all(c.env_id == "BeltSorter-v0" and c.steps is None and c.episodes == 1 for c in cells)
    per_contestant = Counter(_contestant(c) for c in cells)
    main = {(a, a == "jpda", p) for a in ("gnn", "jpda") for p in PREDICTORS}
    arm = {("gnn", True, p) for p in ("kf-ca", "nll-lstm")} | {
        ("jpda", False, p) for p in ("kf-ca", "nll-lstm")
    }
    assert set(per_contestant) == main | arm
    # 2 particle kinds x 3 noise levels x merges on/off x 5 seeds
    assert set(per_contestant.values()) == {2 * 3 * 2 * 5}
    settings = Counter(
        (
            dict(c.env_kwargs)["particle_kind"],
            dict(c.env_kwargs)["noise_std"],
            dict(c.env_kwargs)["merge_touching"],
            c.seed,
        )
        for c in cells
    )
    assert len(settings) == 2 * 3 * 2 * 5 and set(settings.values()) == {len(main | arm)}
    assert {dict(c.env_kwargs)["noise_std"] for c in cells} == {0.0, 2e-4, 5e-4}
    assert all(dict(c.agent_kwargs)["samples"] == 250 for c in cells if c.predictor == "mc-lstm")


def test_the_quick_variant_runs_every_contestant_on_short_episodes(jpda):
    full, quick = expand(load_suite("association")), expand(load_suite("association", quick=True))
    assert {_contestant(c) for c in quick} == {_contestant(c) for c in full}
    assert all(c.steps == 300 and c.seed in (0, 1) for c in quick)
    assert {dict(c.env_kwargs)["noise_std"] for c in quick} == {0.0, 5e-4}
