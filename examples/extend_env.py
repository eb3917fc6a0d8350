"""Extending track-envs with an environment: targets circling a point, sensed by the default sensor.

One module and a ``gym.register`` call. A concrete environment only simulates; the base class
[`track_envs.envs.base.TrackingEnv`][track_envs.envs.TrackingEnv] pads and shuffles the detections, validates
the report, puts the truth into ``info``, scores the reward and renders. The hooks:

* ``_reset_scene`` draws the scene from ``self.np_random`` (the only RNG);
* ``_advance`` moves it one frame on and says whether the scene has ended;
* ``_truth`` returns the targets of the frame;
* ``_canvas`` / ``_draw`` draw it (``render_mode="rgb_array"``).

The default ``_sense`` is the point sensor of the [`SensorSpec`][track_envs.SensorSpec]
(noise, p_detect, clutter). Run it::

    python examples/extend_env.py --steps 50
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from track_envs import SensorSpec
from track_envs.envs import TrackingEnv, Truth

ENV_ID = "CirclingTargets-v0"


class CirclingTargetsEnv(TrackingEnv):
    """Targets on circles of radius 1–3 around the origin at constant angular speed.

    Observation, action and info follow the contract of every point env (docs/architecture.md).

    Args:
        num_targets: Targets in the scene (1–32).
        noise_std: Measurement noise per axis, in scene units.
        render_mode: ``"rgb_array"``, ``"human"`` or ``None``.
    """

    def __init__(self, num_targets: int = 5, noise_std: float = 0.05, render_mode: str | None = None):
        if not 1 <= num_targets <= 32:
            raise ValueError(f"num_targets must be in 1..32, got {num_targets!r}")
        spec = SensorSpec(
            dt=0.1,
            dim=2,
            noise_std=noise_std,
            p_detect=0.95,
            clutter_rate=0.5,
            region_low=(-4.0, -4.0),
            region_high=(4.0, 4.0),
            max_detections=num_targets + 8,
            max_tracks=2 * num_targets + 8,
            units="scene units",
        )
        self.num_targets = num_targets
        self.gospa_c = 1.0
        self._setup_spaces(
            spec, max_targets=num_targets, obs_low=[-8, -8], obs_high=[8, 8], render_mode=render_mode
        )

    def _reset_scene(self) -> None:
        rng = self.np_random
        self._radius = rng.uniform(1.0, 3.0, self.num_targets)
        self._phase = rng.uniform(0.0, 2 * np.pi, self.num_targets)
        self._speed = rng.choice([-1.0, 1.0], self.num_targets) * rng.uniform(0.2, 0.6, self.num_targets)

    def _advance(self) -> bool:
        self._phase = self._phase + self._speed * self.sensor_spec.dt
        return False  # no natural end: max_episode_steps truncates

    def _truth(self) -> Truth:
        xy = self._radius[:, None] * np.stack([np.cos(self._phase), np.sin(self._phase)], axis=1)
        return Truth.all_in_view(np.arange(self.num_targets, dtype=np.int64), xy)

    def _canvas(self) -> Any:
        from track_envs.envs import Canvas

        return Canvas.for_region(self.sensor_spec, width=500)

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        if snapshot is not None and len(snapshot.positions):
            canvas.discs(snapshot.positions, 6, (30, 120, 40))


def register() -> None:
    """Register `ENV_ID` (idempotent)."""
    if ENV_ID not in gym.registry:
        gym.register(ENV_ID, entry_point=f"{__name__}:CirclingTargetsEnv", max_episode_steps=200)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Check the env against the contract and track it with gnn + kf-cv; print the metrics."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100, help="frames to track (default 100)")
    args = parser.parse_args(argv)

    from agents import make_agent, run_episode
    from track_envs.testing import check_tracking_env
    from track_envs.wrappers import TrackingMetrics

    register()
    check_tracking_env(gym.make(ENV_ID), steps=10)
    env = TrackingMetrics(gym.make(ENV_ID, max_episode_steps=args.steps))
    agent = make_agent("gnn", predictor="kf-cv")
    metrics = run_episode(env, agent, seed=0).metrics
    print(f"{ENV_ID}: {args.steps} frames, MOTA {metrics['mota']:.3f}, IDF1 {metrics['idf1']:.3f}")
    return metrics


if __name__ == "__main__":
    main()
