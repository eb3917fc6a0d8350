r"""Joint probabilistic data association (JPDA) tracker, with touching particles as merged blobs.

Every frame, for the ``n`` live tracks and the ``m`` detections:

1. **predict** as gnn: ``N(ŷ_i, S_i)`` from the predictor;
2. **associate probabilistically** (Fortmann, Bar-Shalom and Scheffe: Sonar tracking of multiple
   targets using joint probabilistic data association, 1983): every joint event — each track
   missed, taking one detection of its gate, or, with the merge model, taking together with a
   neighbour one detection as their *merged blob* — is weighed by its likelihood against Poisson
   clutter of density ``λ`` and the detection probability ``p_D``; the marginal probabilities of
   the events are exact per gating cluster (:mod:`agents.jpda._kernels`, one compiled pass;
   clusters of more than ``max_exact`` tracks fall back to loopy belief propagation without merged
   blobs, :mod:`agents.jpda.lbp`, and their tracks are counted in :attr:`JpdaAgent.approximate_tracks`
   — with the coalescence guard (step 3) such tracks take gnn's assignment instead);
3. **update** every track by the moment-matched mixture of its hypotheses (the PDA update):
   exactly for predictors that declare ``MIXTURE_UPDATE`` (the Kalman filters,
   :meth:`predictors.kalman.predictor.KalmanPredictor.update_mixture`); any other Gaussian
   predictor (the belt LSTMs) is updated through the core ``update`` by the mixture's mean
   ``ŷ + p (z̄ − ŷ)`` when the track was more likely detected than not (``p ≥ ½``) and coasts
   otherwise — for a predictor that reports its input, the moment-matched position. Two kinds
   of track take the frame's optimal assignment (gnn's gated Hungarian) instead: tracks not yet
   settled (fewer than 3 updates in a row: their gates span the neighbours), and, with the
   *coalescence guard* (default), tracks that share their gating cluster with other tracks and
   whose most probable hypothesis is not a merged blob — the mixtures of competing tracks pull
   them onto each other (JPDA's coalescence; Blom and Bloem 2000 prune the joint events
   instead). On the belt ≈99 % of the tracks are alone in their cluster;
4. **bookkeeping as gnn** (:class:`agents.gnn.agent.GnnAgent`, shared code): a track counts as seen
   when ``p ≥ ½`` and reports the detection of its most probable hypothesis; the capped second
   chance for tracks and detections left over, deletions after ``max_misses`` misses or on
   leaving the region, births from the detections no track claims, the learnt velocity prior and
   the nozzle-bar roll-out are gnn's.

**Merged blobs.** Touching particles reach the camera as one detection at their area-weighted
centroid (:mod:`track_envs.envs.blobs`). A plain GNN gives that detection to one of the two tracks,
whose filter takes the jump of ≈ half the pair's distance as real motion, or starves the other.
Here a pair of tracks predicted within ``merge_extent`` may jointly take one detection near their
midpoint (covariance in :mod:`agents.jpda._kernels`); each is then updated as a rigid group
member, keeping its predicted offset from the pair's centre, so a join is explained by both tracks
and on separation each piece is closest to its own track's prediction. The env's merge truth
(``info``) is never read.

**Sensor model.** ``p_D`` and ``λ`` come from the sensor spec: ``p_detect`` and
``clutter_rate / area of the observed region``. A sensor that declares no clutter still gets the
floor ``min_clutter_rate`` (detections per frame), so a stray detection is never forced onto a
track; the gate probability ``P_G`` is gnn's ``p_gate``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.gnn.agent import GnnAgent
from agents.jpda import _kernels
from agents.jpda.lbp import lbp_marginals
from agents.jpda.marginals import MAX_EXACT
from agents.jpda.weights import gaussian_log_likelihood, jpda_log_weights
from predictors.base import Capability, Predictor, capability
from track_envs.arguments import check_int, check_non_negative, check_positive
from track_envs.types import Gaussian, SensorSpec

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


class JpdaAgent(GnnAgent):
    """JPDA multi-target tracker with merged-blob events and the PDA update (module docstring).

    Args:
        predictor: A Gaussian predictor's registered name or object, as for gnn.
        p_detect: ``p_D`` in (0, 1]; None: the sensor spec's ``p_detect`` (at least 0.01).
        clutter_density: ``λ``, clutter detections per unit area (volume) of measurement space,
            > 0; None: ``max(clutter_rate, min_clutter_rate)`` over the region's area.
        min_clutter_rate: Floor of the spec's clutter rate (detections per frame), > 0.
        merge_model: Whether two tracks may take one detection as their merged blob.
        merge_extent: Largest distance of two tracks' predictions that may be one blob (sensor
            units), > 0.
        merge_area_std: Std of a blob member's area fraction around ½, >= 0.
        merge_odds: Prior odds of a merged blob against two separate particles for a pair within
            ``merge_extent``, > 0.
        max_exact: Clusters of at most this many tracks are exact; larger ones use loopy belief
            propagation without merged blobs.
        coalescence_guard: A track that shares its cluster with other tracks takes the frame's
            optimal assignment instead of its mixture (unless a merged blob is its most probable
            hypothesis): the mixtures of competing tracks pull them together (module docstring).
            False: every settled track's PDA update.
        **gnn_kwargs: Every other argument of :class:`~agents.gnn.agent.GnnAgent` (``p_gate``,
            ``max_misses``, ``region_margin``, ``velocity_prior``, ``recovery_inflation``, ...,
            and the predictor's keywords), except ``blob_extent`` and ``assignment`` (the merged
            blobs and the association are this tracker's own).
    """

    capabilities = GnnAgent.capabilities  # agents.base: warm-up, covariances, knobs, ...
    traits = GnnAgent.traits

    def __init__(
        self,
        predictor: str | Predictor = "kf-ca",
        *,
        p_detect: float | None = None,
        clutter_density: float | None = None,
        min_clutter_rate: float = MIN_CLUTTER_RATE,
        merge_model: bool = True,
        merge_extent: float = MERGE_EXTENT,
        merge_area_std: float = MERGE_AREA_STD,
        merge_odds: float = 1.0,
        max_exact: int = MAX_EXACT,
        coalescence_guard: bool = True,
        **gnn_kwargs: Any,
    ):
        for name in ("blob_extent", "assignment"):
            if name in gnn_kwargs:
                raise ValueError(
                    f"jpda has no argument {name!r}: its association is probabilistic and merged "
                    "blobs are its merge_model (merge_extent, merge_area_std, merge_odds)"
                )
        super().__init__(predictor, **gnn_kwargs)
        for name in ("blob_extent", "assignment"):  # gnn's, not taken here (warm_up rebuilds from these)
            del self._init_kwargs[name]
        self._init_kwargs.update(
            p_detect=p_detect,
            clutter_density=clutter_density,
            min_clutter_rate=min_clutter_rate,
            merge_model=merge_model,
            merge_extent=merge_extent,
            merge_area_std=merge_area_std,
            merge_odds=merge_odds,
            max_exact=max_exact,
            coalescence_guard=coalescence_guard,
        )
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
        self.max_exact = check_int("max_exact", max_exact, 1)
        self._mixture_update = capability(self.predictor, Capability.MIXTURE_UPDATE)
        self._translate = capability(self.predictor, Capability.TRANSLATE)

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start an episode with sensor ``spec`` (gnn's reset), and fix ``p_D`` and ``λ`` from it."""
        super().reset(spec, seed=seed)
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
        self._settled_share = np.zeros(0)
        self._shift: tuple[NDArray[np.int64], NDArray[np.float64]] | None = None
        self.last_cluster_tracks = np.zeros(0, dtype=np.int64)
        self.last_p_seen = np.zeros(0)
        self._mixture: tuple[NDArray, NDArray, NDArray] | None = None

    def warm_up(self) -> None:
        """gnn's warm-up (:meth:`agents.gnn.agent.GnnAgent.warm_up`) on a throwaway jpda, and the
        kernels its stream does not reach: a blob split, the fallback's likelihoods and gnn's
        second chance between competing tracks."""
        super().warm_up()
        GnnAgent(predictor="kf-cv").warm_up()
        dim = self._spec.dim if self._spec is not None else 2
        mean = np.zeros((1, dim))
        cov = np.eye(dim)[None]
        z = np.zeros((2, dim))
        z[:, 0] = [-0.5, 0.5]
        _kernels.split_blobs(
            mean, cov, z, np.ones(1, np.bool_), np.ones(2, np.bool_), 9.0, 0.1 * np.eye(dim), 0.0, 2.0
        )
        gaussian_log_likelihood(Gaussian(mean, cov), z)

    def _noise_cov(self) -> NDArray[np.float64]:
        assert self._spec is not None
        return np.eye(self._spec.dim) * max((self.noise_scale * self._spec.noise_std) ** 2, 1e-12)

    def _associate_frame(
        self, prediction: Gaussian, predicted: NDArray[np.float64], z: NDArray[np.float64]
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """JPDA marginals and each track's mixture (module docstring, steps 2–4)."""
        cov = np.ascontiguousarray(prediction.cov, dtype=np.float64)
        log_miss_p = 1.0 - self.p_detect * self.p_gate
        frame = _kernels.jpda_frame(
            predicted,
            cov,
            np.ascontiguousarray(z, dtype=np.float64),
            self._gate,
            math.log(self.p_detect) - math.log(self.clutter_density),
            math.log(log_miss_p) if log_miss_p > 0 else -math.inf,
            self.merge_extent if self.merge_model else 0.0,
            self._noise_cov(),
            self.merge_area_std**2,
            math.log(self.merge_odds),
            self.max_exact,
            self._streak >= MERGE_STREAK,
        )
        if frame.status != _kernels.FRAME_OK:
            raise np.linalg.LinAlgError(
                f"predicted covariance S of track {frame.bad} is not positive definite"
            )
        p_seen, z_mean, z_spread, best = frame.p_seen, frame.z_mean, frame.z_spread, frame.best
        settled_big = frame.big[self._streak[frame.big] >= SETTLED_STREAK]
        # the tracks of a cluster above max_exact share it: with the coalescence guard they take
        # gnn's assignment below, as new tracks do, and their marginals would go unused
        if len(settled_big) and not self.coalescence_guard:
            self._approximate(frame, prediction, z)
            self.approximate_tracks += len(frame.big)
        self._settled_share = frame.settled
        np.clip(p_seen, 0.0, 1.0, out=p_seen)  # sums of marginals may pass 1 by an ulp
        self.last_cluster_tracks = frame.cluster_tracks
        det_of_track = np.where(p_seen >= 0.5, best, -1)
        hard = self._streak < SETTLED_STREAK
        if self.coalescence_guard:
            shared = frame.cluster_tracks[frame.cluster_of] > 1
            hard |= shared & (frame.merged_with < 0)
        if hard.any() and len(z):
            self._hard_for(prediction, z, hard, det_of_track, p_seen, z_mean, z_spread)
        self._shift = None
        if self.merge_model and len(z) > 1:
            self._split_blobs(predicted, cov, z, det_of_track, p_seen, z_mean, z_spread)
        if self.recovery_inflation > 1.0 and len(z):
            unseen = det_of_track < 0
            if unseen.any():
                before = det_of_track.copy()
                self._recover(prediction, z, det_of_track)
                recovered = np.flatnonzero(before != det_of_track)
                if len(recovered):  # the second chance is a hard assignment
                    p_seen[recovered] = 1.0
                    z_mean[recovered] = z[det_of_track[recovered]]
                    z_spread[recovered] = 0.0
        self.last_p_seen = p_seen
        self._mixture = (z_mean, z_spread, p_seen)
        if self._mixture_update is not None:
            return det_of_track, z_mean  # (the mixture update reads self._mixture)
        z_tracks = predicted + p_seen[:, None] * (z_mean - predicted)
        z_tracks[det_of_track < 0] = 0.0
        return det_of_track, z_tracks

    def _hard_for(
        self,
        prediction: Gaussian,
        z: NDArray[np.float64],
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
        rows, cols = self._associate(prediction, z, self._gate)
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
        predicted: NDArray[np.float64],
        cov: NDArray[np.float64],
        z: NDArray[np.float64],
        det_of_track: NDArray[np.int64],
        p_seen: NDArray[np.float64],
        z_mean: NDArray[np.float64],
        z_spread: NDArray[np.float64],
    ) -> None:
        """Blobs that fell apart (:func:`agents.jpda._kernels.split_blobs`), in place: the track is
        updated with the pieces' midpoint (where its blob is, so no jump goes into its motion),
        then moved onto the nearer piece (``TRANSLATE``; without it the track stays at the
        midpoint this frame); the other piece is left for a new track."""
        free = np.ones(len(z), dtype=np.bool_)
        free[det_of_track[det_of_track >= 0]] = False
        unseen = (det_of_track < 0) & (self._streak >= MERGE_STREAK)
        if not unseen.any() or free.sum() < 2:
            return
        splits = _kernels.split_blobs(
            predicted,
            cov,
            z,
            unseen,
            free,
            self._gate,
            self._noise_cov(),
            self.merge_area_std**2,
            self.merge_extent,
        )
        if not len(splits.track):
            return
        t = splits.track
        det_of_track[t] = splits.keep
        p_seen[t] = 1.0
        z_mean[t] = splits.midpoint
        z_spread[t] = 0.0
        self.blob_splits += len(t)
        self._settled_share[splits.other] = 0.0  # the second piece is a new track's
        if self._translate is not None:
            self._shift = (t, z[splits.keep] - splits.midpoint)

    def _approximate(self, frame: _kernels.JpdaFrame, prediction: Gaussian, z: NDArray[np.float64]) -> None:
        """Marginals of the clusters above ``max_exact`` by loopy belief propagation (no merged
        blobs), written into ``frame``'s per-track arrays."""
        tracks = frame.big
        sub = Gaussian(prediction.mean[tracks], prediction.cov[tracks])
        loglik, d2 = gaussian_log_likelihood(sub, z)
        weights = jpda_log_weights(loglik, d2 <= self._gate, self.p_detect, self.clutter_density, self.p_gate)
        dets = np.flatnonzero((d2 <= self._gate).any(axis=0))
        pairs, _, clutter = lbp_marginals(weights.log_pair[:, dets], weights.log_miss)
        zd = z[dets]
        p = pairs.sum(axis=1)
        safe = np.where(p > 0, p, 1.0)
        z_mean = np.where(p[:, None] > 0, pairs @ zd / safe[:, None], prediction.mean[tracks])
        diff = zd[None, :, :] - z_mean[:, None, :]
        spread = np.einsum("tj,tjd,tje->tde", pairs / safe[:, None], diff, diff)
        frame.p_seen[tracks] = p
        frame.z_mean[tracks] = z_mean
        frame.z_spread[tracks] = spread
        best = np.argmax(pairs, axis=1)
        frame.best[tracks] = np.where(pairs.max(axis=1) > 0, dets[best], -1)
        frame.clutter[dets] = np.minimum(frame.clutter[dets], clutter)
        settled = self._streak[tracks] >= SETTLED_STREAK
        frame.settled[dets] += pairs[settled].sum(axis=0)

    def _births(self, unused: NDArray[np.int64]) -> NDArray[np.int64]:
        """The detections no track took, less those more likely than not a settled track's: when
        two settled tracks share the probability of two detections, each reports its most probable
        one, and the other is still theirs, not a new particle's."""
        return unused[self._settled_share[unused] < 0.5]

    def _update_tracks(self, state: Any, z_tracks: NDArray[np.float64], seen: NDArray[np.bool_]) -> Any:
        """The PDA update (``update_mixture``), or the core update by the mixture's mean."""
        assert self._mixture is not None
        if self._mixture_update is not None:
            state = self._mixture_update.update_mixture(state, *self._mixture)
        else:
            state = self.predictor.update(state, z_tracks, seen)
        if self._shift is not None and self._translate is not None:
            rows, offset = self._shift
            full = np.zeros((len(state), offset.shape[1]))
            full[rows] = offset
            state = self._translate.translate(state, full)
        return state
