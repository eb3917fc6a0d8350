"""Extending track-envs with an associator: greedy nearest neighbour inside the χ² gate.

A point tracker ([`agents.tracking.tracker.PointTracker`][agents.PointTracker]) owns its tracks' life cycle —
prediction, births, misses, deletions, the learnt velocity prior, the nozzle-bar roll-out, the
report — and leaves one step to a component, the *associator* (the protocol of
[`agents.tracking.associator`][agents.tracking.associator]). Each frame it gets a read-only ``FrameContext``
(the predicted measurements ``N(ŷ_i, S_i)``, the detections ``z_j``, the χ² gate, the tracks' streaks, ...)
and returns an ``Association``: the detection of every track (−1: none) and the measurement each is
updated with; its ``update`` then corrects the predicted state (here the predictor's ``update``).

This one is greedy nearest neighbour: with the squared Mahalanobis costs
``d²_ij = (z_j − ŷ_i)ᵀ S_i⁻¹ (z_j − ŷ_i)``, the tracks take turns in order of their smallest cost,
and each takes its nearest detection still free inside the gate ``d²_ij ≤ γ``. One module and a
``register_associator`` call; it then runs in a tracker with any Gaussian predictor::

    python examples/extend_associator.py --frames 150
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents import Association, FrameContext, PointTracker, make_agent, make_associator, register_associator
from agents.tracking import hard_update, mahalanobis_cost
from predictors import Predictor
from track_envs import SensorSpec
from track_envs.streams import constant_velocity_stream, score_tracker

NAME = "greedy-nearest"


class GreedyNearest:
    """Greedy nearest-neighbour association inside the χ² gate (module docstring)."""

    # declares no capability (agents.tracking.AssociatorCapability): no second chance, no
    # mixture, no shared detections

    def reset(self, spec: SensorSpec, predictor: Predictor) -> None:
        """Nothing to set up: the association keeps no state between frames."""

    def associate(self, frame: FrameContext) -> Association:
        """Each track in order of its smallest cost takes its nearest free detection in the gate."""
        z = frame.z
        n = len(frame.predicted)
        det_of_track = np.full(n, -1, dtype=np.int64)
        if len(z):
            d2 = mahalanobis_cost(frame.prediction, z)
            cost = np.where(d2 <= frame.gate, d2, np.inf)
            free = np.ones(len(z), dtype=np.bool_)
            for i in np.argsort(cost.min(axis=1), kind="stable"):
                row = np.where(free, cost[i], np.inf)
                j = int(np.argmin(row))
                if np.isfinite(row[j]):
                    det_of_track[i], free[j] = j, False
        measurements = np.zeros_like(frame.predicted)
        seen = det_of_track >= 0
        measurements[seen] = z[det_of_track[seen]]
        return Association(det_of_track, measurements)

    def update(
        self, predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]
    ) -> Any:
        """The predictor's ``update`` of the tracks that took a detection."""
        return hard_update(predictor, state, association, seen)

    def warm_up(self, dim: int) -> None:
        """No kernels of its own."""


register_associator(NAME, GreedyNearest)


def main(argv: Sequence[str] | None = None) -> dict[str, dict[str, float]]:
    """Track a constant-velocity stream with the new associator and with gnn; print both."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=150, help="frames of the stream")
    parser.add_argument("--targets", type=float, default=20.0, help="mean number of targets in view")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    stream = constant_velocity_stream(
        np.random.default_rng(args.seed), n_targets=args.targets, frames=args.frames, clutter_rate=1.0
    )
    trackers = {
        NAME: PointTracker("kf-cv", associator=make_associator(NAME)),
        "gnn": make_agent("gnn", predictor="kf-cv"),
    }
    metrics = {name: score_tracker(tracker, stream, seed=args.seed) for name, tracker in trackers.items()}
    print(f"constant-velocity stream, {args.frames} frames, ~{args.targets:g} targets, kf-cv")
    print(f"{'associator':<16}{'MOTA':>8}{'IDF1':>8}{'HOTA':>8}{'ID sw.':>8}")
    for name, m in metrics.items():
        print(f"{name:<16}{m['mota']:8.3f}{m['idf1']:8.3f}{m['hota']:8.3f}{m['id_switches']:8.0f}")
    return metrics


if __name__ == "__main__":
    main()
