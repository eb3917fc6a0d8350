"""The capped second chance of the tracks and detections an association left over.

A collision or a kick moves a particle outside its track's gate; before that detection starts a
new track, the leftovers are matched once more with every predicted covariance scaled by
``recovery_inflation`` ``f``. The second chance is capped in distance: a leftover track may only
take a detection within

.. math::

    r = k_u \\, u + k_σ \\, σ, \\qquad u = \\max(\\lVert \\bar v \\rVert \\, dt,\\;
        \\operatorname{median}_i \\lVert ŷ_i - x̂_i \\rVert)

of its prediction, where ``u`` is the stream's motion per frame (the speed of the velocity prior
``v̄``, or the median predicted displacement of the live tracks when larger), ``σ`` the sensor's
noise std and ``k_u = cap_motion``, ``k_σ = cap_noise``: an inflated gate of a coasting track
grows with every miss, and without the cap it reaches far past the particles next to it.

With clutter declared (``SensorSpec.clutter_rate > 0``, density ``λ`` = rate / region volume) and
misses (``p_D = SensorSpec.p_detect < 1``), a leftover track has either not been detected or been
detected outside its gate, with odds ``(1 − p_D) : (p_D − a)``, where ``a`` is the rate at which
established tracks (updated the last two frames, predicted inside the region) find a detection in
their gate (measured over the last ≈100 frames; ``p_D − a`` at least ``p_D (1 − p_gate)``). The
second chance then takes a pair only when the kicked-target hypothesis beats a miss plus a clutter
detection, ``(p_D − a) N(z; ŷ, f S) ≥ (1 − p_D) λ``
([`agents.tracking._upkeep_kernels.clutter_log_odds`][agents.tracking._upkeep_kernels.clutter_log_odds]):
on a stream whose motion model holds (``a ≈ p_D``) a coasting track no longer takes the clutter
detection or another target's first detection in its inflated gate, while on a belt whose
collisions knock particles out of their gates (``a < p_D``) it still recovers them. Without
clutter, or with ``p_D = 1``, the second chance is as above.

The leftovers' admissible pairs come from the spatial index (a box of half-widths
``sqrt(γ f S_kk)`` around each leftover track, the exact inflated test on the detections inside,
then the cap and the clutter test on that list:
[`agents.tracking._upkeep_kernels.recovery_costs`][agents.tracking._upkeep_kernels.recovery_costs]), and are
assigned as a sparse list
([`agents.tracking.assign.SPARSE_ASSIGNERS`][agents.tracking.assign.SPARSE_ASSIGNERS]): no array of leftover
tracks × leftover detections, so a frame costs ``O(n + m)``.

One component, used by gnn's gated assignment and by jpda alike.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agents.tracking import _upkeep_kernels as _kernels
from agents.tracking.assign import SPARSE_ASSIGNERS
from agents.tracking.associator import FrameContext
from track_envs.values.types import SensorSpec

#: With clutter, the gate's hit rate (the clutter test) is measured on the tracks updated in each
#: of the last ``HIT_STREAK`` frames, ...
HIT_STREAK = 2
#: ... over sums that forget this factor per frame (a memory of ≈100 frames), ...
HIT_MEMORY = 0.99
#: ... starting from this many track-frames at the declared rate ``p_D P_G``.
HIT_PRIOR = 50.0


class SecondChance:
    """The capped second chance with its clutter test (module docstring).

    Args:
        cap_motion: ``k_u``, the jump cap in multiples of the stream's motion per frame, >= 0.
        cap_noise: ``k_σ``, the cap's allowance in multiples of the sensor noise std, >= 0.
        assignment: How the leftover pairs are assigned: ``"hungarian"`` or ``"greedy"``.

    Attributes:
        gate_hits, gate_tries: The forgetting sums of the gate's hit rate (0 until a frame with
            clutter declared counts them).
    """

    def __init__(self, cap_motion: float = 3.0, cap_noise: float = 5.0, assignment: str = "hungarian"):
        for name, value in (("recovery_cap_motion", cap_motion), ("recovery_cap_noise", cap_noise)):
            if not (isinstance(value, int | float) and np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if assignment not in SPARSE_ASSIGNERS:
            raise ValueError(f"assignment must be one of {sorted(SPARSE_ASSIGNERS)}, got {assignment!r}")
        self.cap_motion = float(cap_motion)
        self.cap_noise = float(cap_noise)
        self._assign = SPARSE_ASSIGNERS[assignment]
        self._spec: SensorSpec | None = None
        self.clutter_density = 0.0
        self.gate_hits = 0.0
        self.gate_tries = 0.0

    def reset(self, spec: SensorSpec) -> None:
        """Start an episode: ``λ`` from ``spec`` (detections per unit volume and frame), no hits."""
        self._spec = spec
        self.clutter_density = float(spec.clutter_rate) / float(np.prod(spec.region_size))
        self.gate_hits = 0.0
        self.gate_tries = 0.0

    def gate_hit_rate(self, p_gate: float) -> float:
        """``a``, the probability that a track finds its detection in its gate: the rate of the
        established tracks over the last frames (sums forgetting ``HIT_MEMORY`` per frame), with
        ``HIT_PRIOR`` track-frames at the declared model's ``p_D P_G``."""
        assert self._spec is not None
        declared = self._spec.p_detect * p_gate
        return (self.gate_hits + HIT_PRIOR * declared) / (self.gate_tries + HIT_PRIOR)

    def recover(self, frame: FrameContext, det_of_track: NDArray[np.int64]) -> None:
        """Match the leftover tracks (``det_of_track`` −1) and detections (taken by no track) once
        more with inflated gates within the cap, in place on ``det_of_track``. Call it when there
        are leftovers on both sides. With clutter declared, a pair must also pass the clutter
        test, whose hit rate ``a`` this counts from ``det_of_track`` as it comes in."""
        spec = self._spec
        assert spec is not None, "reset(spec) first"
        prediction = frame.prediction
        if self.clutter_density > 0 and len(frame.streak) == len(det_of_track):
            self._count_gate_hits(det_of_track, prediction.mean, frame.streak)
        leftovers = _kernels.recovery_costs(
            np.ascontiguousarray(prediction.mean, dtype=np.float64),
            np.ascontiguousarray(prediction.cov, dtype=np.float64),
            frame.z,
            det_of_track,
            frame.recovery_inflation,
            frame.gate,
            frame.last,
            frame.motion,
            self.cap_motion,
            self.cap_noise * frame.noise,
            _kernels.clutter_log_odds(
                spec.p_detect, self.clutter_density, self.gate_hit_rate(frame.p_gate), frame.p_gate, spec.dim
            ),
        )
        if leftovers.bad >= 0:
            raise np.linalg.LinAlgError(
                f"predicted covariance S of track {leftovers.bad} is not positive definite"
            )
        if leftovers.wide >= 0:
            with np.errstate(over="ignore", invalid="ignore"):
                cov = np.asarray(prediction.cov)[leftovers.wide] * frame.recovery_inflation
                half = np.sqrt(frame.gate * np.diagonal(cov)[: min(cov.shape[0], 2)])
            raise ValueError(
                f"track {leftovers.wide}: second-chance gate half-width sqrt(gate * f S_kk) = "
                f"{half.tolist()} is not finite (gate {frame.gate!r}, inflation "
                f"{frame.recovery_inflation!r}); a gate must be bounded"
            )
        if leftovers.n_admissible == 0:
            return
        rows, cols = self._assign(
            leftovers.ptr, leftovers.cols, leftovers.cost, len(leftovers.dets), float(frame.gate)
        )
        det_of_track[leftovers.tracks[rows]] = leftovers.dets[cols]

    def _count_gate_hits(
        self, det_of_track: NDArray[np.int64], predicted: NDArray[np.floating], streak: NDArray[np.int64]
    ) -> None:
        """Add this frame's established tracks (updated in each of the last ``HIT_STREAK`` frames,
        predicted inside the observed region: a target that left gives no detection) and those of
        them that found a detection in their gate to the forgetting sums of
        [`gate_hit_rate`][agents.tracking.SecondChance.gate_hit_rate]."""
        assert self._spec is not None
        inside = np.all(
            (predicted >= np.asarray(self._spec.region_low))
            & (predicted <= np.asarray(self._spec.region_high)),
            axis=1,
        )
        established = (streak >= HIT_STREAK) & inside
        tries = int(np.count_nonzero(established))
        hits = int(np.count_nonzero(det_of_track[established] >= 0))
        self.gate_tries = HIT_MEMORY * self.gate_tries + tries
        self.gate_hits = HIT_MEMORY * self.gate_hits + hits
