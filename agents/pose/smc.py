"""SMC multi-person pose tracking with a probabilistic neural pose predictor (Okada et al. 2020).

Okada, Takenaka and Taniguchi, "Multi-person Pose Tracking using Sequential Monte Carlo with
Probabilistic Neural Pose Predictor" (ICRA 2020), Sec. II and IV, Algorithm 1: the agent
``pose-smc`` ([`PoseSmcAgent`][agents.pose.smc.PoseSmcAgent]) is the loop
[`agents.pose.tracker.PoseTracker`][agents.pose.tracker.PoseTracker] (OKS scores, bipartite matching with a
threshold, lifetimes, births, ``F_max`` filters) with the motion hypothesis
[`predictors.pose_lstm.motion.SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion] (``P`` particles per
filter, each a queue of the last ``L`` poses, proposed by the probabilistic pose predictor, resampled and
selected for matched filters; the algorithm is described there).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.pose.tracker import PoseTracker, PoseTrackingOptions
from predictors.pose_lstm.motion import DEFAULT_MODEL, SmcPoseMotion, SmcSettings, pose_model_path
from track_envs.infra.registry import split_keywords, takes_keywords_of

__all__ = ["DEFAULT_MODEL", "PoseSmcAgent"]


class PoseSmcAgent(PoseTracker):
    """The SMC pose tracker of Okada et al. (2020) (``make_agent("pose-smc")``).

    Args:
        model: A ``pose-lstm`` model file, or the name of a shipped one (``predictors/weights``:
            ``pose-lstm-walkers``, the default, and the ablation's retrained
            ``pose-lstm-walkers-no-dropout``, ``-mse`` and ``-no-dropout-mse``).
        max_filters: ``F_max``, the most active filters (the loop's ``max_active``).
        options: The keywords of [`SmcSettings`][predictors.pose_lstm.motion.SmcSettings] (``particles``,
            ``window``, ``alpha``, ``elite``, ``device``, …) and of
            [`PoseTrackingOptions`][agents.pose.tracker.PoseTrackingOptions] but ``max_active``;
            the signature lists them with their defaults.
    """

    @takes_keywords_of(SmcSettings, PoseTrackingOptions, exclude=("max_active",))
    def __init__(self, model: str | Path | None = None, *, max_filters: int = 100, **options: Any) -> None:
        from predictors.pose_lstm.device import TorchPosePredictor
        from predictors.pose_lstm.predictor import PosePredictor

        if not (isinstance(max_filters, int) and max_filters >= 1):
            raise ValueError(f"max_filters (F_max) must be an integer >= 1, got {max_filters!r}")
        settings, loop = split_keywords(SmcSettings, options)
        motion = SmcPoseMotion(None, **settings)
        super().__init__(motion, max_active=max_filters, **loop)
        path = pose_model_path(model)
        device = motion.settings.device
        try:
            motion.predictor = PosePredictor(path) if device is None else TorchPosePredictor(path, device)
        except ModuleNotFoundError as exc:
            if exc.name != "torch":
                raise
            hint = 'pose-smc needs torch (its pose predictor): pip install "track-envs[torch]"'
            raise ModuleNotFoundError(hint, name="torch") from exc
