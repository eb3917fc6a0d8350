"""The probabilistic pose predictor of Okada et al. (2020): network, batched predictor and training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.pose_lstm.motion import SmcPoseMotion, SmcSettings
    from predictors.pose_lstm.network import PosePredictorNet
    from predictors.pose_lstm.predictor import PosePredictor

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
