"""Which agents can run on which kind of detection file.

A file holds either points (MOT det.txt, wide CSV) or poses (COCO keypoint results, PoseTrack
JSON: [`track_envs.io.poses`][track_envs.io.poses]). An agent can run on a file when it does not need truth
(``needs_truth``: an oracle reads the env's ``info``, which a file does not have) and its
``position_rank`` fits the file (1: points, 2: poses): read from the agents' declared traits
([`agents.base.agent_traits`][agents.agent_traits]), not from a list of names.
"""

from __future__ import annotations

from agents.base import AGENTS, agent_traits, available_agents

#: The kinds of detection file and the ``position_rank`` of the agents that track them.
FILE_KINDS = {"point": 1, "pose": 2}

_RANK_WORDS = {1: "points", 2: "poses (17 keypoints)"}


def why_not(agent: object, kind: str) -> str | None:
    """Why ``agent`` (a registered name or an agent object) cannot run on a ``kind`` file
    (``"point"`` or ``"pose"``), None if it can."""
    if isinstance(agent, str):
        name, traits = agent, agent_traits(AGENTS.factory(agent))
    else:
        name, traits = type(agent).__name__, agent_traits(agent)
    if traits.needs_truth:
        return f"{name!r} needs truth (the env's info), which a file does not have"
    rank = int(traits.position_rank)
    if rank != FILE_KINDS[kind]:
        tracks = _RANK_WORDS.get(rank, f"targets of position rank {rank}")
        return f"{name!r} tracks {tracks}, not {kind}s"
    return None


def file_agents(kind: str) -> list[str]:
    """The registered agents that can run on a ``kind`` file."""
    return [name for name in available_agents() if why_not(name, kind) is None]


def check_file_agent(agent: object, kind: str, flag: str = "--agent ") -> None:
    """ValueError saying why ``agent`` cannot run on a ``kind`` file, listing those that can
    (``flag``: the option the user typed, prefixed to the message)."""
    reason = why_not(agent, kind)
    if reason is not None:
        raise ValueError(f"{flag}{reason}; agents for {kind} files: {', '.join(file_agents(kind))}")
