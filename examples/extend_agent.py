"""Extending track-envs with an agent: a nearest-neighbour tracker with a fixed gate.

One module and a ``register_agent`` call. An agent (the [`agents.base.Agent`][agents.Agent] protocol) has
two calls:

* ``reset(spec, *, seed=None)`` binds it to the env's [`SensorSpec`][track_envs.SensorSpec] and
  starts an episode with no tracks (``seed`` seeds whatever random stream it draws from);
* ``act(obs) -> report``: the observation (``"detections"``, ``"mask"``) in, the report of its
  live tracks out (ids, positions, the detection row each was updated with, mask), built with
  [`track_envs.contracts.report.pack_report`][track_envs.contracts.pack_report]. The report is the env's
  action.

It validates the observation with
[`track_envs.contracts.observation.check_observation`][track_envs.contracts.check_observation] (a
``ValueError`` naming what is wrong) and declares what it is as class attributes (the traits of
[`agents.base`][agents.base]: ``position_rank``, ``max_targets``, ``needs_truth``, ``takes_predictor``), which
the bench and ``track run`` read to decide where it applies. Run it::

    python examples/extend_agent.py --steps 200
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from agents import AgentTraits, register_agent
from track_envs import SensorSpec
from track_envs.contracts import check_observation, pack_report

NAME = "nearest"
#: The default gate in multiples of the sensor's noise std.
GATE_STDS = 10.0


class NearestNeighbourAgent:
    """Nearest-neighbour tracker: constant-position prediction, a fixed distance gate, Hungarian.

    Each frame, for the ``n`` live tracks at positions ``p_i`` and the ``m`` detections ``z_j``:

    1. cost ``d_ij = ‖p_i − z_j‖``, admissible where ``d_ij ≤ g`` (the gate);
    2. the assignment with the most admissible pairs and, among those, the least total distance
       (scipy's ``linear_sum_assignment``, inadmissible pairs priced above any admissible sum);
    3. an assigned track moves to its detection; the others keep their position and count a miss,
       and a track with more than ``max_misses`` consecutive misses is deleted;
    4. every detection left over starts a track with a new id (as many as ``max_tracks`` allows).

    Args:
        gate: The gate ``g`` in sensor units, > 0; ``None``: `GATE_STDS` times the sensor's
            noise std.
        max_misses: Consecutive misses a track survives, >= 0.
    """

    # declared traits (agents.AgentTraits; these are the defaults, written out to show them):
    # point targets (positions (D,)), any number of them, a tracker (not an oracle), no predictor=
    traits = AgentTraits(position_rank=1, max_targets=None, needs_truth=False, takes_predictor=False)

    def __init__(self, *, gate: float | None = None, max_misses: int = 3):
        if gate is not None and not (isinstance(gate, int | float) and math.isfinite(gate) and gate > 0):
            raise ValueError(f"gate must be None or a finite distance > 0, got {gate!r}")
        if not (isinstance(max_misses, int) and max_misses >= 0):
            raise ValueError(f"max_misses must be an integer >= 0, got {max_misses!r}")
        self.gate = gate
        self.max_misses = max_misses
        self._spec: SensorSpec | None = None

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start an episode with sensor ``spec`` (``seed`` is unused: the tracker is deterministic)."""
        self._spec = spec
        self._gate = self.gate if self.gate is not None else GATE_STDS * max(float(spec.noise_std), 1e-6)
        self._ids = np.zeros(0, dtype=np.int64)
        self._positions = np.zeros((0, spec.dim))
        self._misses = np.zeros(0, dtype=np.int64)
        self._next_id = 0

    def act(self, obs: Mapping[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
        """Associate, update, delete and start tracks; report the live ones.

        Raises:
            ValueError: for an observation that breaks the contract (``check_observation``).
            RuntimeError: before `reset`.
        """
        if self._spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        rows, z = check_observation(obs, self._spec)
        det = self._associate(z)  # (n,) detection index per track, -1: none
        seen = det >= 0
        positions = self._positions.copy()
        positions[seen] = z[det[seen]]
        updated_with = np.full(len(det), -1, dtype=np.int64)
        updated_with[seen] = rows[det[seen]]
        misses = np.where(seen, 0, self._misses + 1)
        keep = misses <= self.max_misses
        unused = np.ones(len(z), dtype=bool)
        unused[det[seen]] = False
        born = np.flatnonzero(unused)[: self._spec.max_tracks - int(keep.sum())]
        self._ids = np.concatenate([self._ids[keep], self._next_id + np.arange(len(born))])
        self._next_id += len(born)
        self._positions = np.concatenate([positions[keep], z[born]])
        self._misses = np.concatenate([misses[keep], np.zeros(len(born), dtype=np.int64)])
        detection = np.concatenate([updated_with[keep], rows[born]])
        return pack_report(self._ids, self._positions, detection, self._spec.max_tracks)

    def _associate(self, z: NDArray[np.float64]) -> NDArray[np.int64]:
        """The detection index of every track (−1: none within the gate)."""
        n, m = len(self._positions), len(z)
        det = np.full(n, -1, dtype=np.int64)
        if n == 0 or m == 0:
            return det
        distance = np.linalg.norm(self._positions[:, None, :] - z[None, :, :], axis=-1)
        admissible = distance <= self._gate
        # above the largest admissible total: the most admissible pairs win first
        cost = np.where(admissible, distance, self._gate * (min(n, m) + 1))
        tracks, dets = linear_sum_assignment(cost)
        ok = admissible[tracks, dets]
        det[tracks[ok]] = dets[ok]
        return det


def register() -> None:
    """Register the tracker as `NAME` (its keyword arguments are the class's)."""
    register_agent(NAME, NearestNeighbourAgent)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Check the agent against the contract and track SineTarget-v0 with it; print the metrics."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="frames to track (default 200)")
    parser.add_argument("--gate", type=float, default=None, help="gate in sensor units (default 10 σ)")
    args = parser.parse_args(argv)

    import gymnasium as gym

    import track_envs  # noqa: F401  (registers the envs)
    from agents import make_agent, run_episode
    from track_envs.testing import check_agent
    from track_envs.wrappers import TrackingMetrics

    register()
    check_agent(make_agent(NAME, gate=args.gate), gym.make("SineTarget-v0", clutter_rate=1.0, max_tracks=16))
    env = TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=args.steps))
    agent = make_agent(NAME, gate=args.gate)
    metrics = run_episode(env, agent, seed=0).metrics
    print(f"SineTarget-v0 + {NAME}, {args.steps} frames: mean error {metrics['mean_error']:.3f}")
    return metrics


if __name__ == "__main__":
    main()
