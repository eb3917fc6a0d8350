"""Extending track-envs with a metric: the fraction of frames in which every target is tracked.

A metric is a small streaming class (the [`track_envs.metrics.Metric`][track_envs.metrics.Metric] protocol, in
the style of py-motmetrics' accumulator): ``update(truth, detection_ids, report)`` once per frame with
exactly what the env hands out (padded, fixed shapes), ``compute()`` for the summary and
``reset()`` for a new episode. Pass it to [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics]; nothing
registers it. Here: a frame counts as *covered* when every visible target has a reported track
within ``radius`` of it (a distance, not an assignment: it is a coverage measure). Run it::

    python examples/extend_metric.py --steps 50
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from track_envs.metrics import MetricTraits


class Coverage:
    """Fraction of frames in which every visible target has a reported track within ``radius``.

    ``coverage = #{frames t : max_i min_j ‖x_i(t) − y_j(t)‖ ≤ radius} / #frames``, over the visible
    targets ``x_i`` and the live report rows ``y_j``; a frame without visible targets is covered.
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(self, radius: float) -> None:
        if not radius > 0:
            raise ValueError(f"radius must be > 0, got {radius!r}")
        self.radius = float(radius)
        self.reset()

    def reset(self) -> None:
        self.frames = 0
        self.covered = 0

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        targets = np.asarray(truth["positions"])[np.asarray(truth["visible"], dtype=bool)]
        tracks = np.asarray(report["positions"])[np.asarray(report["mask"]) == 1]
        self.frames += 1
        if len(targets) == 0:
            self.covered += 1
        elif len(tracks):
            distance = np.linalg.norm(targets[:, None, :] - tracks[None, :, :], axis=-1)
            self.covered += int(distance.min(axis=1).max() <= self.radius)

    def compute(self) -> dict[str, float]:
        return {"coverage": self.covered / self.frames if self.frames else float("nan")}


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Score gnn + kf-cv on SineTarget-v0 with the default metrics plus `Coverage`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100, help="frames (default 100)")
    parser.add_argument("--radius", type=float, default=0.25, help="coverage radius (default 0.25)")
    args = parser.parse_args(argv)

    import track_envs  # noqa: F401  (registers the envs)
    from agents import make_agent, run_episode
    from track_envs.wrappers import TrackingMetrics, default_metrics

    base = gym.make("SineTarget-v0", max_episode_steps=args.steps)
    env = TrackingMetrics(base, metrics=[*default_metrics(base), Coverage(radius=args.radius)])
    agent = make_agent("gnn", predictor="kf-cv")
    metrics = run_episode(env, agent, seed=0).metrics
    print(
        f"SineTarget-v0, {args.steps} frames: coverage {metrics['coverage']:.3f}, RMSE {metrics['rmse']:.3f}"
    )
    return metrics


if __name__ == "__main__":
    main()
