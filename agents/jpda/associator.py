"""jpda's association: JPDA marginals with merged blobs, the PDA mixture update, blob splits and
the coalescence guard (the tracker is [`agents.jpda.agent`][agents.jpda.agent]; the method there).

Per frame the compiled pass [`agents.jpda._kernels.jpda_frame`][agents.jpda._kernels.jpda_frame] gives every
track's marginal probability of being seen, the mean and spread of its detections' mixture and its most
probable hypothesis (exact per gating cluster; clusters above ``max_exact`` by loopy belief propagation,
[`agents.jpda.lbp`][agents.jpda.lbp], or with the coalescence guard gnn's assignment). Tracks not yet settled
and, with the guard, tracks sharing their cluster take the frame's optimal assignment instead; blobs
that fell apart are split ([`agents.jpda._kernels.split_blobs`][agents.jpda._kernels.split_blobs]); leftover
tracks get the capped second chance of [`agents.tracking.second_chance`][agents.tracking.second_chance]. The
update is the moment-matched mixture (``MIXTURE_UPDATE`` predictors) or the core update by the mixture's mean.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.jpda import _kernels
from agents.jpda.lbp import lbp_marginals
from agents.jpda.marginals import MAX_EXACT
from agents.jpda.weights import gaussian_log_likelihood, jpda_log_weights
from agents.tracking.assign import associate_hungarian
from agents.tracking.associator import (
    Association,
    AssociatorCapability,
    FrameContext,
)
from agents.tracking.gated import GatedAssignment
from agents.tracking.second_chance import SecondChance
from agents.tracking.tracker import PointTracker
from predictors.base import Capability, Predictor, capability
from track_envs.infra.arguments import check_int, check_non_negative, check_positive
from track_envs.infra.blas_threads import frame_blas
from track_envs.infra.spatial import candidate_pairs
from track_envs.values.types import Gaussian, SensorSpec

#: Default floor of the clutter rate (detections per frame) for sensors that declare none.
MIN_CLUTTER_RATE = 0.01
#: Default largest distance of two predictions that may be one merged blob (sensor units; metres
#: on the belt: about a particle's length).
MERGE_EXTENT = 0.006
#: Updates in a row before a track's hypotheses are mixed (before, it takes gnn's assignment).
SETTLED_STREAK = 3
#: Updates in a row before a track may form or split a merged blob: a new track's prediction is
#: too wide to tell a blob from its own particle (its velocity is barely known).
MERGE_STREAK = 3
#: Default std of a blob member's area fraction around ½: 0, the blob of two equal particles is
#: centred between them (particles of unequal sizes: their spread of area fractions).
MERGE_AREA_STD = 0.0

Mixture = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
Shift = tuple[NDArray[np.int64], NDArray[np.float64]]


class JpdaAssociator:
    """JPDA association with merged blobs and the PDA update (module docstring; the arguments as
    [`JpdaAgent`][agents.jpda.agent.JpdaAgent]'s, plus the second chance's caps)."""

    capabilities = frozenset(AssociatorCapability)

    def __init__(
        self,
        p_detect: float | None = None,
        clutter_density: float | None = None,
        min_clutter_rate: float = MIN_CLUTTER_RATE,
        merge_model: bool = True,
        merge_extent: float = MERGE_EXTENT,
        merge_area_std: float = MERGE_AREA_STD,
        merge_odds: float = 1.0,
        max_exact: int = MAX_EXACT,
        coalescence_guard: bool = True,
        rigid_merge: bool = True,
        recovery_cap_motion: float = 3.0,
        recovery_cap_noise: float = 5.0,
    ):
        if not isinstance(coalescence_guard, bool | np.bool_):
            raise ValueError(f"coalescence_guard must be True or False, got {coalescence_guard!r}")
        self.coalescence_guard = bool(coalescence_guard)
        if p_detect is not None and not (
            isinstance(p_detect, int | float | np.floating) and 0.0 < float(p_detect) <= 1.0
        ):
            raise ValueError(f"p_detect must be None or a probability in (0, 1], got {p_detect!r}")
        self.p_detect_arg = None if p_detect is None else float(p_detect)
        self.clutter_density_arg = (
            None if clutter_density is None else check_positive("clutter_density", clutter_density)
        )
        self.min_clutter_rate = check_positive("min_clutter_rate", min_clutter_rate)
        if not isinstance(merge_model, bool | np.bool_):
            raise ValueError(f"merge_model must be True or False, got {merge_model!r}")
        self.merge_model = bool(merge_model)
        self.merge_extent = check_positive("merge_extent", merge_extent)
        self.merge_area_std = check_non_negative("merge_area_std", merge_area_std)
        self.merge_odds = check_positive("merge_odds", merge_odds)
        if not isinstance(rigid_merge, bool | np.bool_):
            raise ValueError(f"rigid_merge must be True or False, got {rigid_merge!r}")
        self.rigid_merge = bool(rigid_merge)
        self.max_exact = check_int("max_exact", max_exact, 1)
        self.second_chance = SecondChance(recovery_cap_motion, recovery_cap_noise)

    def reset(self, spec: SensorSpec, predictor: Predictor) -> None:
        """Start an episode with sensor ``spec``: fix ``p_D`` and ``λ`` from it, and the
        predictor's capabilities this update uses."""
        self._mixture_update = capability(predictor, Capability.MIXTURE_UPDATE)
        self._translate = capability(predictor, Capability.TRANSLATE)
        self.second_chance.reset(spec)
        self.p_detect = (
            self.p_detect_arg if self.p_detect_arg is not None else max(float(spec.p_detect), 0.01)
        )
        if self.clutter_density_arg is not None:
            self.clutter_density = self.clutter_density_arg
        else:
            extent = np.asarray(spec.region_high, np.float64) - np.asarray(spec.region_low, np.float64)
            area = float(np.prod(extent))
            if not (math.isfinite(area) and area > 0):
                raise ValueError(
                    f"the sensor's region {spec.region_low}..{spec.region_high} has no finite positive "
                    "area; give jpda clutter_density"
                )
            self.clutter_density = max(float(spec.clutter_rate), self.min_clutter_rate) / area
        self.approximate_tracks = 0
        self.blob_splits = 0
        self.last_cluster_tracks = np.zeros(0, dtype=np.int64)
        self.last_p_seen = np.zeros(0)

    def warm_up(self, dim: int) -> None:
        """The kernels a tracker's warm-up stream does not reach: gnn's second chance between
        competing tracks (a gnn tracker's warm-up), a blob split and the fallback's likelihoods."""
        PointTracker(predictor="kf-cv", associator=GatedAssignment()).warm_up()
        mean = np.zeros((1, dim))
        cov = np.eye(dim)[None]
        z = np.zeros((2, dim))
        z[:, 0] = [-0.5, 0.5]
        _kernels.split_blobs(
            mean, cov, z, np.ones(1, np.bool_), np.ones(2, np.bool_), 9.0, 0.1 * np.eye(dim), 0.0, 2.0
        )
        gaussian_log_likelihood(Gaussian(mean, cov), z)

    def _noise_cov(self, frame: FrameContext) -> NDArray[np.float64]:
        return np.eye(frame.spec.dim) * max((frame.noise_scale * frame.spec.noise_std) ** 2, 1e-12)

    def associate(self, frame: FrameContext) -> Association:
        """JPDA marginals and each track's mixture ([`agents.jpda.agent`][agents.jpda.agent], steps 2–4)."""
        predicted, z = frame.predicted, frame.z
        cov = np.ascontiguousarray(frame.prediction.cov, dtype=np.float64)
        jf = self._marginals(frame, cov)
        p_seen, z_mean, z_spread = jf.p_seen, jf.z_mean, jf.z_spread
        settled_share = jf.settled
        self.last_cluster_tracks = jf.cluster_tracks
        det_of_track = np.where(p_seen >= 0.5, jf.best, -1)
        hard = frame.streak < SETTLED_STREAK
        if self.coalescence_guard:
            shared = jf.cluster_tracks[jf.cluster_of] > 1
            hard |= shared & (jf.merged_with < 0)
        if hard.any() and len(z):
            self._hard_for(frame, hard, det_of_track, p_seen, z_mean, z_spread)
        shift: Shift | None = None
        if self.merge_model and len(z) > 1:
            shift = self._split_blobs(frame, cov, det_of_track, p_seen, z_mean, z_spread, settled_share)
        if frame.recovery_inflation > 1.0 and len(z):
            unseen = det_of_track < 0
            if unseen.any():
                before = det_of_track.copy()
                self.second_chance.recover(frame, det_of_track)
                recovered = np.flatnonzero(before != det_of_track)
                if len(recovered):  # the second chance is a hard assignment
                    p_seen[recovered] = 1.0
                    z_mean[recovered] = z[det_of_track[recovered]]
                    z_spread[recovered] = 0.0
        self.last_p_seen = p_seen
        mixture: Mixture = (z_mean, z_spread, p_seen)
        # the detections no track took, less those more likely than not a settled track's: when
        # two settled tracks share the probability of two detections, each reports its most
        # probable one, and the other is still theirs, not a new particle's
        may_start = settled_share < 0.5
        if self._mixture_update is not None:
            return Association(det_of_track, z_mean, may_start, (mixture, shift))
        z_tracks = predicted + p_seen[:, None] * (z_mean - predicted)
        z_tracks[det_of_track < 0] = 0.0
        return Association(det_of_track, z_tracks, may_start, (mixture, shift))

    def _marginals(self, frame: FrameContext, cov: NDArray[np.float64]) -> _kernels.JpdaFrame:
        """The compiled frame pass, with the clusters above ``max_exact`` by loopy belief
        propagation when there is no coalescence guard."""
        log_miss_p = 1.0 - self.p_detect * frame.p_gate
        # a rigid pair's members keep the offset of their last estimates; otherwise (and without
        # merged blobs, where the anchors are unused) that of their predictions
        rigid = self.merge_model and self.rigid_merge
        anchor = np.ascontiguousarray(frame.last, dtype=np.float64) if rigid else frame.predicted
        jf = _kernels.jpda_frame_anchored(
            frame.predicted,
            cov,
            np.ascontiguousarray(frame.z, dtype=np.float64),
            frame.gate,
            math.log(self.p_detect) - math.log(self.clutter_density),
            math.log(log_miss_p) if log_miss_p > 0 else -math.inf,
            self.merge_extent if self.merge_model else 0.0,
            self._noise_cov(frame),
            self.merge_area_std**2,
            math.log(self.merge_odds),
            self.max_exact,
            frame.streak >= MERGE_STREAK,
            anchor,
        )
        if jf.status != _kernels.FRAME_OK:
            raise np.linalg.LinAlgError(f"predicted covariance S of track {jf.bad} is not positive definite")
        settled_big = jf.big[frame.streak[jf.big] >= SETTLED_STREAK]
        # the tracks of a cluster above max_exact share it: with the coalescence guard they take
        # gnn's assignment, as new tracks do, and their marginals would go unused
        if len(settled_big) and not self.coalescence_guard:
            self._approximate(jf, frame)
            self.approximate_tracks += len(jf.big)
        np.clip(jf.p_seen, 0.0, 1.0, out=jf.p_seen)  # sums of marginals may pass 1 by an ulp
        return jf

    def _hard_for(
        self,
        frame: FrameContext,
        young: NDArray[np.bool_],
        det_of_track: NDArray[np.int64],
        p_seen: NDArray[np.float64],
        z_mean: NDArray[np.float64],
        z_spread: NDArray[np.float64],
    ) -> None:
        """Tracks ``young`` take gnn's assignment instead of their mixture, in place: those not
        yet settled, and (the coalescence guard) those whose cluster holds other tracks, unless
        their most probable hypothesis is a merged blob.

        A new track's velocity is barely known, so its gate spans the neighbouring particles, and
        tracks whose gates share detections pull each other's mixtures together: the coalescence
        of JPDA (Blom and Bloem: Probabilistic data association avoiding track coalescence, 2000,
        prune the joint events instead — JPDA*). Such a track's detection is the one the joint
        optimal assignment of the frame gives it (gnn's gated Hungarian over all tracks), or none;
        the marginals still decide the merged blobs, the blob splits, the births and, for every
        track alone in its cluster (on the belt ≈99 % of them), the PDA update.
        """
        z = frame.z
        rows, cols = associate_hungarian(frame.prediction, z, frame.gate)
        hard = np.full(len(young), -1, dtype=np.int64)
        hard[rows] = cols
        t = np.flatnonzero(young)
        det = hard[t]
        det_of_track[t] = det
        hit = det >= 0
        p_seen[t] = hit.astype(np.float64)
        z_mean[t[hit]] = z[det[hit]]
        z_spread[t] = 0.0

    def _split_blobs(
        self,
        frame: FrameContext,
        cov: NDArray[np.float64],
        det_of_track: NDArray[np.int64],
        p_seen: NDArray[np.float64],
        z_mean: NDArray[np.float64],
        z_spread: NDArray[np.float64],
        settled_share: NDArray[np.float64],
    ) -> Shift | None:
        """Blobs that fell apart ([`agents.jpda._kernels.split_blobs`][agents.jpda._kernels.split_blobs]), in
        place: the track is updated with the pieces' midpoint (where its blob is, so no jump goes into its
        motion), then moved onto the nearer piece (the returned shift, with ``TRANSLATE``; without it the
        track stays at the midpoint this frame); the other piece is left for a new track."""
        z = frame.z
        free = np.ones(len(z), dtype=np.bool_)
        free[det_of_track[det_of_track >= 0]] = False
        unseen = (det_of_track < 0) & (frame.streak >= MERGE_STREAK)
        if not unseen.any() or free.sum() < 2:
            return None
        splits = _kernels.split_blobs(
            frame.predicted,
            cov,
            z,
            unseen,
            free,
            frame.gate,
            self._noise_cov(frame),
            self.merge_area_std**2,
            self.merge_extent,
        )
        if not len(splits.track):
            return None
        t = splits.track
        det_of_track[t] = splits.keep
        p_seen[t] = 1.0
        z_mean[t] = splits.midpoint
        z_spread[t] = 0.0
        self.blob_splits += len(t)
        settled_share[splits.other] = 0.0  # the second piece is a new track's
        if self._translate is not None:
            return (t, z[splits.keep] - splits.midpoint)
        return None

    def _approximate(self, jf: _kernels.JpdaFrame, frame: FrameContext) -> None:
        """Marginals of the clusters above ``max_exact`` by loopy belief propagation (no merged
        blobs), written into ``jf``'s per-track arrays: over those clusters' tracks and the
        detections inside their gates (``n_big × m_big`` weights, one propagation)."""
        tracks = jf.big
        prediction, z, gate = frame.prediction, frame.z, frame.gate
        sub = Gaussian(prediction.mean[tracks], prediction.cov[tracks])
        # the likelihoods of the detections inside the tracks' gate boxes only (spatial index)
        cand = np.unique(_gate_candidates(sub, z, gate))
        loglik, d2 = gaussian_log_likelihood(sub, z[cand])
        in_gate = d2 <= gate
        keep = in_gate.any(axis=0)
        dets = cand[keep]
        weights = jpda_log_weights(
            loglik[:, keep], in_gate[:, keep], self.p_detect, self.clutter_density, frame.p_gate
        )
        pairs, _, clutter = lbp_marginals(weights.log_pair, weights.log_miss)
        zd = z[dets]
        p = pairs.sum(axis=1)
        safe = np.where(p > 0, p, 1.0)
        with frame_blas():  # (n_big × m_big) @ (m_big × 2) would split across BLAS threads
            weighted = pairs @ zd
        z_mean = np.where(p[:, None] > 0, weighted / safe[:, None], prediction.mean[tracks])
        diff = zd[None, :, :] - z_mean[:, None, :]
        spread = np.einsum("tj,tjd,tje->tde", pairs / safe[:, None], diff, diff)
        jf.p_seen[tracks] = p
        jf.z_mean[tracks] = z_mean
        jf.z_spread[tracks] = spread
        best = np.argmax(pairs, axis=1)
        jf.best[tracks] = np.where(pairs.max(axis=1) > 0, dets[best], -1)
        jf.clutter[dets] = np.minimum(jf.clutter[dets], clutter)
        settled = frame.streak[tracks] >= SETTLED_STREAK
        jf.settled[dets] += pairs[settled].sum(axis=0)

    def update(
        self, predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]
    ) -> Any:
        """The PDA update (``update_mixture``), or the core update by the mixture's mean; then the
        split blobs' tracks moved onto their piece (``translate``)."""
        mixture, shift = association.detail
        if self._mixture_update is not None:
            state = self._mixture_update.update_mixture(state, *mixture)
        else:
            state = predictor.update(state, association.measurements, seen)
        if shift is not None and self._translate is not None:
            rows, offset = shift
            full = np.zeros((len(state), offset.shape[1]))
            full[rows] = offset
            state = self._translate.translate(state, full)
        return state


def _gate_candidates(prediction: Gaussian, z: NDArray[np.float64], gate: float) -> NDArray[np.int64]:
    """The detections inside some track's gate box ``|z_k − ŷ_k| ≤ sqrt(γ S_kk)`` (first two axes,
    widened as the compiled gates' boxes; with repeats), from the spatial index: a superset of
    the detections with ``d² ≤ γ``."""
    mean = np.asarray(prediction.mean, dtype=np.float64)
    K = min(mean.shape[1], 2)
    var = np.diagonal(np.asarray(prediction.cov, dtype=np.float64), axis1=1, axis2=2)[:, :K]
    with np.errstate(invalid="ignore", over="ignore"):
        half = np.sqrt(gate * var) * (1.0 + _kernels.BOX_MARGIN) + 1e-12 * np.abs(mean[:, :K])
    half = np.where(half < _kernels.BOX_ALL, half, _kernels.BOX_ALL)
    _, cols = candidate_pairs(mean, half, z, what="track")
    return cols
