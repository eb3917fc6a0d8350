"""Which agents compete in the results tables (the bench's knowledge, not the agents' contract).

A table marks the best value of a metric among the trackers only: neither a reference that keeps
no identity from one frame to the next (the no-tracking ``detections`` floor, whose e1 and so
e_mean are 0 by construction: [`REFERENCE_AGENTS`][track_apps.bench.ranking.REFERENCE_AGENTS]) nor an oracle
that reads the truth (an agent that declares ``needs_truth``, [`agents.base.AgentTraits`][agents.AgentTraits])
is ever marked best.
"""

from __future__ import annotations

from agents.base import AGENTS, agent_traits

#: The registered agents that are references, not trackers: no identity survives a frame.
REFERENCE_AGENTS = frozenset({"detections"})


def agent_is_ranked(name: str) -> bool:
    """Whether agent ``name`` competes in the results tables: not a reference
    ([`REFERENCE_AGENTS`][track_apps.bench.ranking.REFERENCE_AGENTS]) and sees no truth (not ``needs_truth``).
    A name not registered here (a record from an agent of your own) is ranked."""
    if name not in AGENTS.names():
        return True
    return name not in REFERENCE_AGENTS and not agent_traits(AGENTS.factory(name)).needs_truth
