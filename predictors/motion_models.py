"""Every motion model of the project in one listing: its name, its kind and the agents that take it.

Three kinds of motion model exist, each with its own registry, because the trackers that use them
hold different state and ask different questions (docs/architecture.md, "Three kinds of motion
model"):

* ``"gaussian"`` — a [`Predictor`][predictors.Predictor]: a Gaussian per track over a batch of
  tracks ([`predictors.PREDICTORS`][predictors.PREDICTORS]); taken as ``predictor=`` by the agents that
  declare ``takes_predictor`` (gnn, one-step);
* ``"displacement"`` — a particle displacement model
  ([`predictors.displacement.DISPLACEMENT_MODELS`][predictors.displacement.DISPLACEMENT_MODELS]); taken as
  ``model=`` by ``pf``;
* ``"pose"`` — a pose hypothesis motion ([`predictors.pose.POSE_MOTIONS`][predictors.pose.POSE_MOTIONS]),
built by the pose
  tracker that uses it.

[`motion_models`][predictors.motion_models.motion_models] lists them all; ``track list`` prints it.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

#: The kinds of motion model, with what each is.
KINDS: dict[str, str] = {
    "gaussian": "Gaussian predictor over a batch of tracks (predictors.base.Predictor)",
    "displacement": "particle displacement model (predictors.displacement.DisplacementModel)",
    "pose": "pose hypothesis motion (predictors.pose.PoseMotion)",
}

#: The agents that take a Gaussian predictor (``predictor=``); the agents declare it too
#: (``takes_predictor``), and a test keeps the two equal.
GAUSSIAN_AGENTS = ("gnn", "jpda", "one-step")


@dataclass(frozen=True)
class MotionModel:
    """One registered motion model.

    Attributes:
        name: Its registered name (unique within its kind).
        kind: One of `KINDS`.
        agents: The registered agents that take it.
        summary: The first line of its factory's docstring.
    """

    name: str
    kind: str
    agents: tuple[str, ...]
    summary: str


def _summary(factory: Callable[..., Any]) -> str:
    """The first paragraph of the factory's docstring without markup (cross-reference links and
    roles show their text), cut to 100 characters."""
    paragraph = " ".join((inspect.getdoc(factory) or "").split("\n\n")[0].split())
    paragraph = re.sub(r"\[`?([^`\[\]]+)`?\]\[[\w.]*\]", r"\1", paragraph)
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", paragraph).replace("``", "")
    return text if len(text) <= 100 else text[:99].rsplit(" ", 1)[0] + " …"


def motion_models(kind: str | None = None) -> list[MotionModel]:
    """Every registered motion model (of ``kind`` only, when given), Gaussian ones first.

    Raises:
        ValueError: for an unknown ``kind``, listing the valid ones.
    """
    if kind is not None and kind not in KINDS:
        raise ValueError(f"unknown motion model kind {kind!r}; valid kinds are {list(KINDS)}")
    from predictors import displacement, pose
    from predictors.registry import PREDICTORS

    models = [
        MotionModel(n, "gaussian", GAUSSIAN_AGENTS, _summary(PREDICTORS.factory(n)))
        for n in PREDICTORS.names()
    ]
    for registry, listing in (
        (displacement.DISPLACEMENT_MODELS, displacement.motion_models()),
        (pose.POSE_MOTIONS, pose.motion_models()),
    ):
        models += [MotionModel(n, k, tuple(a), _summary(registry.factory(n))) for n, k, a in listing]
    return [m for m in models if kind is None or m.kind == kind]
