"""The probabilistic pose predictor of Okada et al. (2020): network, batched predictor and training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.pose_lstm.motion import SmcPoseMotion, SmcSettings
    from predictors.pose_lstm.network import PosePredictorNet
    from predictors.pose_lstm.predictor import PosePredictor

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "SmcPoseMotion": "predictors.pose_lstm.motion",
    "SmcSettings": "predictors.pose_lstm.motion",
    "PosePredictorNet": "predictors.pose_lstm.network",
    "PosePredictor": "predictors.pose_lstm.predictor",
}

__all__ = [
    "PosePredictor",
    "PosePredictorNet",
    "SmcPoseMotion",
    "SmcSettings",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
