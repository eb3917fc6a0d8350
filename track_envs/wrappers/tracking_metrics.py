"""TrackingMetrics: score every report of an episode and put the summary into the final ``info``."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from track_envs.metrics import Metric
from track_envs.metrics.base import metric_traits
from track_envs.metrics.defaults import point_metrics

__all__ = ["TrackingMetrics", "default_metrics", "point_metrics"]


def default_metrics(env: gym.Env) -> list[Metric]:
    """The metrics that fit an environment's family: its ``default_metrics()`` method if it has one
    (each environment family names its own), else [`point_metrics`][track_envs.metrics.point_metrics] with
    ``c = gospa_c``."""
    try:
        factory = env.get_wrapper_attr("default_metrics")
    except AttributeError:
        factory = None
    if callable(factory):
        return list(factory())
    return point_metrics(float(env.get_wrapper_attr("gospa_c")))


class TrackingMetrics(gym.Wrapper):
    """Accumulates tracking metrics over an episode; ``info["episode_metrics"]`` on its last step.

    Every ``step(report)`` scores the report against the truth of the frame it answers (the
    ``info`` of the previous ``reset``/``step``). When the episode ends, terminated or truncated,
    the step's ``info`` gets ``"episode_metrics"``: one flat ``dict[str, float]`` merging every
    metric's ``compute()`` (later metrics win on a shared key).

    Merged detections: when the env's ``info`` has ``"detection_ids_merged"`` (every truth id
    behind each detection row, BeltSorter-v0's touching particles), metrics whose class declares
    ``traits = MetricTraits(accepts_merged_ids=True)`` receive that (max_detections, K) array as
    ``detection_ids`` and count an association of a merged detection to either particle's track
    as correct (see `track_envs.metrics.merged`); every other metric receives
    ``info["detection_ids"]``.

    An environment without ground truth (``has_truth = False``, DetectionReplay-v0) gets no
    metric that needs truth: a metric declares that it does with
    ``traits = MetricTraits(needs_truth=True)`` (every metric of [`track_envs.metrics`][track_envs.metrics]
    does; the default, as for agents, is ``False``;
    [`track_envs.metrics.base.metric_traits`][track_envs.metrics.metric_traits]). The last step's
    ``info["episode_metrics_note"]`` says what was skipped.

    Args:
        env: A tracking environment (wrapped or not).
        metrics: Streaming metrics (see [`track_envs.metrics.Metric`][track_envs.metrics.Metric]); default
            [`default_metrics`][track_envs.wrappers.default_metrics] for the environment.
    """

    def __init__(self, env: gym.Env, metrics: Sequence[Metric] | None = None):
        super().__init__(env)
        self.metrics: list[Metric] = list(metrics) if metrics is not None else default_metrics(env)
        self.note: str | None = None
        try:
            has_truth = bool(env.get_wrapper_attr("has_truth"))
        except AttributeError:
            has_truth = True
        if not has_truth:
            skipped = [type(m).__name__ for m in self.metrics if metric_traits(m).needs_truth]
            self.metrics = [m for m in self.metrics if not metric_traits(m).needs_truth]
            self.note = "the environment has no ground truth: metrics that need it are skipped" + (
                f" ({', '.join(skipped)})" if skipped else " (every point metric: MOTA, IDF1, GOSPA, e1, e2)"
            )
        self._truth: dict[str, NDArray] | None = None
        self._detection_ids: NDArray[np.int64] | None = None
        self._merged_ids: NDArray[np.int64] | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        for metric in self.metrics:
            metric.reset()
        self._keep(info)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self._truth is None or self._detection_ids is None:
            raise RuntimeError("step() called before reset(); call env.reset(seed=...) first")
        obs, reward, terminated, truncated, info = self.env.step(action)
        merged = self._merged_ids if self._merged_ids is not None else self._detection_ids
        for metric in self.metrics:
            ids = merged if metric_traits(metric).accepts_merged_ids else self._detection_ids
            metric.update(self._truth, ids, action)
        self._keep(info)
        if terminated or truncated:
            info = dict(info)
            info["episode_metrics"] = self.episode_metrics()
            if self.note is not None:
                info["episode_metrics_note"] = self.note
        return obs, float(reward), terminated, truncated, info

    def episode_metrics(self) -> dict[str, float]:
        """The metrics of the episode so far, one flat dict of floats."""
        merged: dict[str, float] = {}
        for metric in self.metrics:
            merged.update({k: float(v) for k, v in metric.compute().items()})
        return merged

    def _keep(self, info: dict[str, Any]) -> None:
        self._truth = info["truth"]
        self._detection_ids = info["detection_ids"]
        self._merged_ids = info.get("detection_ids_merged")
