"""SMC multi-person pose tracking with a probabilistic neural pose predictor (Okada et al. 2020).

Okada, Takenaka and Taniguchi, "Multi-person Pose Tracking using Sequential Monte Carlo with
Probabilistic Neural Pose Predictor" (ICRA 2020), Sec. II and IV, Algorithm 1: the agent
``pose-smc`` (:class:`PoseSmcAgent`) is the loop :class:`agents.pose.baseline.PoseTracker` (OKS
scores, bipartite matching with a threshold, lifetimes, births, ``F_max`` filters) with the motion
hypothesis :class:`predictors.pose_lstm.motion.SmcPoseMotion` (``P`` particles per filter, each a
queue of the last ``L`` poses, proposed by the probabilistic pose predictor, resampled and
selected for matched filters; the algorithm is described there).
"""

from __future__ import annotations

from pathlib import Path

from agents.pose.baseline import PoseTracker
from predictors.pose_lstm.motion import DEFAULT_MODEL, SmcPoseMotion

__all__ = ["DEFAULT_MODEL", "PoseSmcAgent"]


class PoseSmcAgent(PoseTracker):
    """The SMC pose tracker of Okada et al. (2020) (``make_agent("pose-smc")``).

    Args:
        model: A ``pose-lstm`` model file (default: the shipped ``pose-lstm-walkers``).
        particles, window, alpha, elite, epistemic, aleatoric, fixed_sigma, recurrence,
            share_windows: see :class:`~predictors.pose_lstm.motion.SmcPoseMotion` (defaults
            P = 300, L = 10, α = 0.45, e = 0.15).
        max_filters: ``F_max``, the most active filters (100).
        oks_threshold, assignment, keypoint_threshold, min_pose_score, min_keypoints,
            initial_lifetime, area_factor, report_coasting: see :class:`agents.pose.baseline.PoseTracker`.
    """

    def __init__(
        self,
        model: str | Path | None = None,
        *,
        particles: int = 300,
        window: int = 10,
        alpha: float = 0.45,
        elite: float = 0.15,
        epistemic: bool = True,
        aleatoric: bool = True,
        fixed_sigma: float | None = None,
        recurrence: str = "window",
        share_windows: bool = True,
        max_filters: int = 100,
        oks_threshold: float = 0.3,
        assignment: str = "hungarian",
        keypoint_threshold: float = 0.0,
        min_pose_score: float = 0.0,
        min_keypoints: int = 1,
        initial_lifetime: int = 0,
        area_factor: float = 0.25,
        report_coasting: bool = False,
    ) -> None:
        from predictors.pose_lstm.predictor import PosePredictor

        if not (isinstance(max_filters, int) and max_filters >= 1):
            raise ValueError(f"max_filters (F_max) must be an integer >= 1, got {max_filters!r}")
        motion = SmcPoseMotion(
            None,
            particles=particles,
            window=window,
            alpha=alpha,
            elite=elite,
            epistemic=epistemic,
            aleatoric=aleatoric,
            fixed_sigma=fixed_sigma,
            recurrence=recurrence,
            share_windows=share_windows,
        )
        super().__init__(
            motion,
            oks_threshold=oks_threshold,
            assignment=assignment,
            keypoint_threshold=keypoint_threshold,
            min_pose_score=min_pose_score,
            min_keypoints=min_keypoints,
            initial_lifetime=initial_lifetime,
            area_factor=area_factor,
            report_coasting=report_coasting,
            max_active=max_filters,
        )
        motion.predictor = PosePredictor(DEFAULT_MODEL if model is None else model)
