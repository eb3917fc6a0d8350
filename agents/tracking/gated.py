"""gnn's association: the χ² gate, the optimal (or greedy) assignment and the capped second chance.

For the ``n`` live tracks and ``m`` detections of a frame: the admissible pairs of the χ² gate at
``p_gate`` from the spatial index and the exact squared Mahalanobis test, then the optimal
assignment with a per-track miss cost (lone pairs, then each connected component of the pairs on
its own) or the greedy one ([`agents.tracking.assign`][agents.tracking.assign]); tracks and detections left
over then get the second chance of [`agents.tracking.second_chance`][agents.tracking.second_chance] when
``recovery_inflation > 1``. Nothing of size ``n × m`` is built: a frame costs ``O(n + m)`` at a bounded
density. Every track is updated by the predictor's ``update`` with its detection; the others coast.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tracking.assign import ASSOCIATORS
from agents.tracking.associator import Association, AssociatorCapability, FrameContext, hard_update
from agents.tracking.second_chance import SecondChance
from predictors.base import Predictor
from track_envs.infra.assignment.sparse_path import solve_with_misses
from track_envs.values.types import SensorSpec


class GatedAssignment:
    """Gated optimal assignment with the capped second chance (module docstring).

    Args:
        assignment: ``"hungarian"`` (optimal) or ``"greedy"``.
        recovery_cap_motion: ``k_u`` of the second chance's cap
            (`agents.tracking.second_chance`), >= 0.
        recovery_cap_noise: ``k_σ`` of the cap, >= 0.
    """

    capabilities = frozenset({AssociatorCapability.SECOND_CHANCE})

    def __init__(
        self, assignment: str = "hungarian", recovery_cap_motion: float = 3.0, recovery_cap_noise: float = 5.0
    ):
        if assignment not in ASSOCIATORS:
            raise ValueError(f"assignment must be one of {sorted(ASSOCIATORS)}, got {assignment!r}")
        self.assignment = assignment
        self._pairs = ASSOCIATORS[assignment]
        self.second_chance = SecondChance(recovery_cap_motion, recovery_cap_noise, assignment)

    def reset(self, spec: SensorSpec, predictor: Predictor) -> None:
        """Start an episode (the second chance's clutter test reads ``spec``)."""
        self.second_chance.reset(spec)

    def assign(self, frame: FrameContext) -> NDArray[np.int64]:
        """The detection index of every track (−1: none): gate and assign, then the capped second
        chance of the leftovers.

        Returns:
            (n,) int64 detection index per track.
        """
        n, m = len(frame.prediction.mean), len(frame.z)
        det_of_track = np.full(n, -1, dtype=np.int64)
        track_rows, det_cols = self._pairs(frame.prediction, frame.z, frame.gate)
        det_of_track[track_rows] = det_cols
        if len(track_rows) < min(n, m) and frame.recovery_inflation > 1.0:
            self.second_chance.recover(frame, det_of_track)
        return det_of_track

    def associate(self, frame: FrameContext) -> Association:
        """[`assign`][agents.tracking.GatedAssignment.assign], each seen track measured by its detection."""
        det_of_track = self.assign(frame)
        # rows of coasting tracks (detection −1) are never read by the update
        z = frame.z
        return Association(det_of_track, z[det_of_track] if len(z) else np.zeros_like(frame.predicted))

    def update(
        self, predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]
    ) -> Any:
        """The predictor's ``update`` of the seen tracks."""
        return hard_update(predictor, state, association, seen)

    def warm_up(self, dim: int) -> None:
        """Compile the solver of the components too large for a dense matrix (a tracker's warm-up
        stream has none; a live run meets one in its first frames)."""
        one = np.array([0, 1], dtype=np.int64)
        solve_with_misses(one, one[:1], np.zeros(1), 1, 1.0)
