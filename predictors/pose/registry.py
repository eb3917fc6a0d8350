"""The registry of pose hypothesis motions by name.

``"constant-velocity"`` ([`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose], the
motion of ``pose-baseline``) and ``"smc"``
([`predictors.pose_lstm.motion.SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion] with its pose
predictor loaded, the motion of ``pose-smc``). Each pose agent builds its own motion from its keyword
arguments; the registry names them and builds one for a
[`agents.pose.tracker.PoseTracker`][agents.pose.tracker.PoseTracker] of your own.
"""

from __future__ import annotations

import os
from typing import Any

from predictors.pose.constant_velocity import ConstantVelocityPose
from track_envs.infra.registry import Registry, check_keywords, named_arguments

#: The kind of model this registry holds (one of the three kinds of motion model).
KIND = "pose"
#: The agent that takes each motion, by motion name.
AGENTS = {"constant-velocity": ("pose-baseline",), "smc": ("pose-smc",)}


def smc(model: str | os.PathLike[str] | None = None, **kwargs: Any) -> Any:
    """[`predictors.pose_lstm.motion.SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion] with the pose
    predictor of ``model`` (a ``pose-lstm`` model file; ``None``: the shipped ``pose-lstm-walkers``);
    ``kwargs`` are the keywords of
    [`predictors.pose_lstm.motion.SmcSettings`][predictors.pose_lstm.motion.SmcSettings] (``particles``,
    ``window``, …)."""
    from predictors.pose_lstm.motion import DEFAULT_MODEL, SmcPoseMotion
    from predictors.pose_lstm.predictor import PosePredictor

    accepted = [a for a in named_arguments(SmcPoseMotion) if a != "predictor"]
    check_keywords("pose motion 'smc'", kwargs, ["model", *accepted])
    return SmcPoseMotion(PosePredictor(DEFAULT_MODEL if model is None else model), **kwargs)


#: Pose motion factories by name.
POSE_MOTIONS = Registry("pose motion")
POSE_MOTIONS.register("constant-velocity", ConstantVelocityPose)
POSE_MOTIONS.register("smc", smc)


def motion_models() -> list[tuple[str, str, tuple[str, ...]]]:
    """Every registered pose motion as ``(name, kind, agents that take it)``."""
    return [(name, KIND, AGENTS.get(name, ())) for name in POSE_MOTIONS.names()]
