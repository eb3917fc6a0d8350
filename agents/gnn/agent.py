"""Global nearest neighbour (GNN) multi-target tracker (the tracker of Pollithy et al. 2020).

A [`PointTracker`][agents.PointTracker] (predict, births, misses, deletions, the learnt
velocity prior, the nozzle-bar roll-out, the report) composed with gnn's association,
[`GatedAssignment`][agents.tracking.GatedAssignment]: squared Mahalanobis costs, χ² gate at ``p_gate``,
Hungarian (or greedy) assignment with a per-track miss cost, then the capped second chance of the
tracks and detections left over ([`agents.tracking.second_chance`][agents.tracking.second_chance]: covariances
scaled by ``recovery_inflation``, jumps capped at ``k_u u + k_σ σ``, and with clutter declared the clutter
test), wrapped in the merged blobs of [`SharedBlobs`][agents.tracking.SharedBlobs] when
``blob_extent > 0``. Assigned tracks are corrected with their detection, the others coast.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from agents.tracking.gated import GatedAssignment
from agents.tracking.knobs import NOISE_SCALE, P_GATE, RECOVERY_INFLATION
from agents.tracking.merges import SharedBlobs
from agents.tracking.tracker import PointTracker
from agents.tracking.velocity_prior import FLOW_WINDOW, MIN_FLOW_SAMPLES, YOUNG_STREAK, VelocityPriorState
from predictors.base import Predictor

__all__ = ["FLOW_WINDOW", "MIN_FLOW_SAMPLES", "YOUNG_STREAK", "GnnAgent", "VelocityPriorState"]


class GnnAgent(PointTracker):
    """GNN multi-target tracker: χ² gate, Hungarian, pluggable predictor (Pollithy et al. 2020).

    A [`PointTracker`][agents.PointTracker] built with gnn's associator (module
    docstring); it adds no behaviour of its own.

    Args:
        predictor: Registered predictor name (``"kf-ca"``, ``"kf-cv"``, ``"random-walk"``, ...) or an
            object implementing the Predictor protocol (its methods are checked here).
        p_gate: Gate probability of the χ² gate (Pollithy et al. 2020: 0.999).
        assignment: ``"hungarian"`` (optimal) or ``"greedy"``.
        max_misses: A track is deleted after more than this many consecutive misses.
        region_margin: Tracks are deleted when their prediction leaves the observed region grown
            by this much (sensor units) on every side; ``math.inf`` turns this deletion off (tracks
            are then deleted after ``max_misses`` misses only).
        velocity_prior: ``"auto"`` (learnt online, see the module docstring), ``None`` (the
            predictor's own default) or a fixed velocity (D,).
        recovery_inflation: Covariance scale of the second-chance association of leftover tracks
            and detections (1 turns it off).
        velocity_fallback: With ``velocity_prior="auto"``, the velocity (D,) new tracks start from
            until the prior is learnt (e.g. the belt speed); None: the predictor's default.
        recovery_cap_motion: ``k_u``, the second-chance jump cap in multiples of the stream's
            motion per frame (see the module docstring), >= 0. The default 3 lets a track that
            coasted a few frames behind or ahead of its particle (a new track whose first velocity
            was off, a kick) take it back, and keeps it from jumping tens of millimetres onto
            another particle (at 1 m/s and 200 Hz: 15 mm).
        recovery_cap_noise: ``k_σ``, the cap's allowance in multiples of the sensor noise std, >= 0.
        blob_extent: Merged blobs ([`agents.tracking.merges`][agents.tracking.merges]): a track left without a
            detection whose prediction lies within this distance (sensor units) of a detection another track
            took, itself predicted within it, shares that detection; the blob's tracks are updated as a
            rigid group, each keeping its predicted offset. 0 (the default) turns sharing off.
        noise_scale: Factor ``k`` on the sensor's declared noise std that the predictor assumes
            (``R = (k σ)² I``) and that the second-chance cap uses, > 0 (default 1). Needs a
            predictor that declares the ``NOISE_SCALE`` capability (``set_noise_scale``: the Kalman
            filters) unless it is 1.
        predict_sorting: With a nozzle bar in the sensor spec, report each deleted track's
            predicted crossing (the sorting channel; default True). ``False`` skips the
            roll-outs (a learned predictor steps its network once per roll-out frame) and reports
            no sorting channel, for throughput when no valve is driven.
        **predictor_kwargs: Passed to ``make_predictor`` when ``predictor`` is a name; a keyword
            that neither the agent nor that predictor takes raises
            [`UnknownArgumentError`][track_envs.infra.registry.UnknownArgumentError] listing the arguments of
            both.

    Live knobs: [`p_gate`][agents.PointTracker.p_gate],
    [`recovery_inflation`][agents.PointTracker.recovery_inflation] and
    [`noise_scale`][agents.PointTracker.noise_scale] may be set between frames of a running episode (each is
    checked, and the next frame uses it); this is how GateTuning-v0 ([`track_apps.tuning`][track_apps.tuning])
    acts on the tracker.
    """

    def __init__(
        self,
        predictor: str | Predictor = "kf-ca",
        *,
        p_gate: float = P_GATE.default,
        assignment: str = "hungarian",
        max_misses: int = 2,
        region_margin: float = 0.0,
        velocity_prior: str | NDArray | None = "auto",
        recovery_inflation: float = RECOVERY_INFLATION.default,
        velocity_fallback: NDArray | None = None,
        recovery_cap_motion: float = 3.0,
        recovery_cap_noise: float = 5.0,
        blob_extent: float = 0.0,
        noise_scale: float = NOISE_SCALE.default,
        predict_sorting: bool = True,
        **predictor_kwargs: Any,
    ):
        gated = GatedAssignment(assignment, recovery_cap_motion, recovery_cap_noise)
        shared = SharedBlobs(gated, blob_extent)  # (checks blob_extent)
        associator = shared if shared.blob_extent > 0 else gated
        super().__init__(
            predictor,
            associator=associator,
            p_gate=p_gate,
            max_misses=max_misses,
            region_margin=region_margin,
            velocity_prior=velocity_prior,
            recovery_inflation=recovery_inflation,
            velocity_fallback=velocity_fallback,
            noise_scale=noise_scale,
            predict_sorting=predict_sorting,
            owner=type(self),
            **predictor_kwargs,
        )
        self.assignment = assignment
        self.recovery_cap_motion = float(recovery_cap_motion)
        self.recovery_cap_noise = float(recovery_cap_noise)
        self.blob_extent = shared.blob_extent
