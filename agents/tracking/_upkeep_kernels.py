"""Compiled (numba) per-frame bookkeeping of the GNN tracker: one pass over tracks and detections.

After the association of a frame, track ``i`` holds the detection ``det_i`` it was assigned
(−1: none). Then, per track,

.. math::

    \\text{seen}_i = [det_i \\ge 0], \\qquad
    \\text{misses}_i \\leftarrow \\begin{cases} 0 & \\text{seen}_i \\\\
        \\text{misses}_i + 1 & \\text{else} \\end{cases}, \\qquad
    \\text{streak}_i \\leftarrow \\begin{cases} \\text{streak}_i + 1 & \\text{seen}_i \\\\
        0 & \\text{else} \\end{cases},

    \\text{keep}_i = [\\text{misses}_i \\le M] \\wedge
        (\\text{seen}_i \\vee \\text{low} \\le ŷ_i \\le \\text{high}),

    \\text{young}_i = \\text{seen}_i \\wedge [s_{lo} \\le \\text{streak}_i \\le s_{hi}],

and the detections no track took start new tracks.

Kernels and their results (inputs are float64 / int64 C-contiguous arrays; no input is written
except the flow's ring buffer):

* [`frame_upkeep`][agents.tracking._upkeep_kernels.frame_upkeep] →
[`FrameUpkeep`][agents.tracking._upkeep_kernels.FrameUpkeep] ``(seen, misses, streak, keep, n_keep, young,
  n_young, unused)``: the per-track counters and masks above.
* [`learn_flow`][agents.tracking._upkeep_kernels.learn_flow] →
[`FlowUpdate`][agents.tracking._upkeep_kernels.FlowUpdate] ``(n_samples, head, fresh, median, variance,
  updated)``: the velocity prior's ring buffer after a push, and the re-estimated prior.
* [`recovery_costs`][agents.tracking._upkeep_kernels.recovery_costs] →
[`RecoveryCosts`][agents.tracking._upkeep_kernels.RecoveryCosts]
``(tracks, dets, ptr, cols, cost, n_admissible,
  bad, wide, cap)``: the admissible pairs of the second chance of the leftover tracks and
  detections (through the spatial index: no leftover-tracks × leftover-detections array).
* [`survivors_and_births`][agents.tracking._upkeep_kernels.survivors_and_births] →
[`TrackArrays`][agents.tracking._upkeep_kernels.TrackArrays] ``(ids, misses, streak, estimate,
  detection_rows)``: the per-track arrays of the kept and the new tracks.
* [`median_and_mad_variance`][agents.tracking._upkeep_kernels.median_and_mad_variance] →
``(median, variance)``; [`median_displacement`][agents.tracking._upkeep_kernels.median_displacement] → a
float.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from agents.tracking._kernels import cholesky_lower, gated_pairs
from track_envs.infra.compiled import njit
from track_envs.values.types import FloatArray

IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


class FrameUpkeep(NamedTuple):
    """Result of [`frame_upkeep`][agents.tracking._upkeep_kernels.frame_upkeep]: new arrays, one row per track
    (the inputs are not written).

    Attributes:
        seen: (n,) ``det_i >= 0``, the tracks updated this frame.
        misses: (n,) consecutive misses after this frame.
        streak: (n,) consecutive updates after this frame.
        keep: (n,) the tracks that survive the frame.
        n_keep: Number of True in ``keep``.
        young: (n,) seen tracks whose streak lies in ``[s_lo, s_hi]``.
        n_young: Number of True in ``young``.
        unused: The detections (ascending) that no track took.
    """

    seen: BoolArray
    misses: IntArray
    streak: IntArray
    keep: BoolArray
    n_keep: int
    young: BoolArray
    n_young: int
    unused: IntArray


class FlowUpdate(NamedTuple):
    """Result of [`learn_flow`][agents.tracking._upkeep_kernels.learn_flow]: the ring buffer's counters after
    the push and the estimate.

    Attributes:
        n_samples: Samples held (at most the buffer's length ``W``).
        head: Row the next sample goes to.
        fresh: Samples pushed since the last estimate (0 when ``updated``).
        median: (D,) per-axis median of the buffer's velocities (zeros unless ``updated``).
        variance: (D,) ``(1.4826 · MAD)²`` per axis (zeros unless ``updated``).
        updated: Whether ``median`` and ``variance`` are a new estimate.
    """

    n_samples: int
    head: int
    fresh: int
    median: FloatArray
    variance: FloatArray
    updated: bool


class RecoveryCosts(NamedTuple):
    """Result of [`recovery_costs`][agents.tracking._upkeep_kernels.recovery_costs]: the second-chance problem
    of the leftovers, as a sparse list of its admissible pairs.

    Attributes:
        tracks: (k,) the tracks without a detection, ascending.
        dets: (l,) the detections no track took, ascending.
        ptr: (k + 1,) leftover track ``a``'s pairs are ``ptr[a]:ptr[a + 1]``.
        cols: The leftover detection (an index into ``dets``) of each pair, ascending within a track.
        cost: The inflated squared Mahalanobis cost of each pair: ``<= gate``, within the
            distance cap and, with clutter, passing the clutter test.
        n_admissible: Number of pairs (``len(cost)``).
        bad: −1, or a leftover track whose inflated covariance is not positive definite (the
            other fields are then not meaningful).
        wide: −1, or a leftover track whose inflated gate's half-width is not finite (the other
            fields are then not meaningful).
        cap: The distance cap ``r`` (``inf`` when it was not computed).
    """

    tracks: IntArray
    dets: IntArray
    ptr: IntArray
    cols: IntArray
    cost: FloatArray
    n_admissible: int
    bad: int
    wide: int
    cap: float


class TrackArrays(NamedTuple):
    """Result of [`survivors_and_births`][agents.tracking._upkeep_kernels.survivors_and_births]: the per-track
    arrays of the kept tracks, in order, followed by the new ones.

    Attributes:
        ids: Track ids.
        misses: Consecutive misses (0 for a new track).
        streak: Consecutive updates (1 for a new track).
        estimate: (n, D) last estimates (a new track's detection).
        detection_rows: Observation row of each track's last detection.
    """

    ids: IntArray
    misses: IntArray
    streak: IntArray
    estimate: FloatArray
    detection_rows: IntArray


@njit(cache=True)
def frame_upkeep(
    det_of_track: IntArray,
    misses: IntArray,
    streak: IntArray,
    predicted: FloatArray,
    low: FloatArray,
    high: FloatArray,
    max_misses: int,
    young_streak: tuple[int, int],
    n_detections: int,
) -> FrameUpkeep:
    """The per-track counters and masks of a frame (see the module docstring for the equations).

    Args:
        det_of_track: (n,) detection index of each track, −1 when it coasted.
        misses: (n,) consecutive misses before this frame.
        streak: (n,) consecutive updates before this frame.
        predicted: (n, D) predicted measurement ``ŷ`` of each track.
        low: (D,) lower corner of the region where coasting tracks are kept.
        high: (D,) upper corner of that region.
        max_misses: ``M``, the most consecutive misses a kept track may have.
        young_streak: ``(s_lo, s_hi)``, the update streaks of the young tracks.
        n_detections: ``m``, detections in the frame.

    Returns:
        [`FrameUpkeep`][agents.tracking._upkeep_kernels.FrameUpkeep]
            ``(seen, misses, streak, keep, n_keep, young, n_young, unused)``: new arrays (the inputs are not
            written), and ``unused``, the detections (ascending) that no track took.
    """
    n = det_of_track.shape[0]
    D = predicted.shape[1]
    seen = np.empty(n, dtype=np.bool_)
    misses_out = np.empty(n, dtype=np.int64)
    streak_out = np.empty(n, dtype=np.int64)
    keep = np.empty(n, dtype=np.bool_)
    young = np.empty(n, dtype=np.bool_)
    used = np.zeros(n_detections, dtype=np.bool_)
    n_keep = 0
    n_young = 0
    n_used = 0
    for i in range(n):
        det = det_of_track[i]
        hit = det >= 0
        seen[i] = hit
        if hit:
            if not used[det]:  # a merged blob's detection may update several tracks
                used[det] = True
                n_used += 1
            misses_out[i] = 0
            streak_out[i] = streak[i] + 1
        else:
            misses_out[i] = misses[i] + 1
            streak_out[i] = 0
        inside = True
        for d in range(D):
            if not (predicted[i, d] >= low[d] and predicted[i, d] <= high[d]):
                inside = False
        keep[i] = misses_out[i] <= max_misses and (inside or hit)
        n_keep += keep[i]
        young[i] = hit and young_streak[0] <= streak_out[i] <= young_streak[1]
        n_young += young[i]
    unused = np.empty(n_detections - n_used, dtype=np.int64)
    k = 0
    for j in range(n_detections):
        if not used[j]:
            unused[k] = j
            k += 1
    return FrameUpkeep(seen, misses_out, streak_out, keep, n_keep, young, n_young, unused)


@njit(cache=True)
def median_and_mad_variance(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per column of ``v`` (n, D), n >= 1: the median ``m_j`` and the robust variance
    ``(1.4826 · median_i |v_ij − m_j|)²`` (the MAD scaled to a normal's standard deviation)."""
    n, dim = v.shape
    median = np.empty(dim)
    variance = np.empty(dim)
    column = np.empty(n)
    for j in range(dim):
        for i in range(n):
            column[i] = v[i, j]
        median[j] = np.median(column)
        for i in range(n):
            column[i] = abs(v[i, j] - median[j])
        variance[j] = (1.4826 * np.median(column)) ** 2
    return median, variance


@njit(cache=True)
def learn_flow(
    samples: FloatArray,
    n_samples: int,
    head: int,
    fresh: int,
    estimate: FloatArray,
    last: FloatArray,
    young: BoolArray,
    dt: float,
    min_samples: int,
) -> FlowUpdate:
    """Push the velocities ``(x̂_i − x̂_i^{prev}) / dt`` of the ``young`` tracks into a ring buffer;
    re-estimate the prior
    ([`median_and_mad_variance`][agents.tracking._upkeep_kernels.median_and_mad_variance] of the buffer) when
    enough is new.

    The estimate is refreshed once ``n_samples >= min_samples`` and at least
    ``max(1, n_samples // 8)`` samples arrived since the last one: with every sample while the
    buffer is small, every 16 samples once a window of 128 is full (a median of 128 samples moves
    little with 16 of them; this keeps the per-frame cost low on a dense stream).

    Args:
        samples: (W, D) ring buffer of the last ``W`` velocity samples, written in place.
        n_samples: Samples held so far (at most ``W``).
        head: Row the next sample goes to.
        fresh: Samples pushed since the last estimate.
        estimate: (n, D) current estimates; last: (n, D) the previous frame's.
        young: (n,) the tracks that give a sample.
        dt: Frame period.
        min_samples: Fewest samples for an estimate.

    Returns:
        [`FlowUpdate`][agents.tracking._upkeep_kernels.FlowUpdate]
            ``(n_samples, head, fresh, median (D,), variance (D,), updated)``: the buffer's state after the
            push and, when ``updated``, the new estimate (else zeros).
    """
    window, dim = samples.shape
    for i in range(young.shape[0]):
        if young[i]:
            for d in range(dim):
                samples[head, d] = (estimate[i, d] - last[i, d]) / dt
            head = (head + 1) % window
            n_samples = min(n_samples + 1, window)
            fresh += 1
    if n_samples < min_samples or fresh < max(1, n_samples // 8):
        return FlowUpdate(n_samples, head, fresh, np.zeros(dim), np.zeros(dim), False)
    median, variance = median_and_mad_variance(samples[:n_samples])
    return FlowUpdate(n_samples, head, 0, median, variance, True)


@njit(cache=True)
def median_displacement(predicted: FloatArray, last: FloatArray) -> float:
    """Median over the tracks of ``‖ŷ_i − x̂_i‖``: how far the tracks are predicted to move in a frame."""
    n, dim = predicted.shape
    if n == 0:
        return 0.0
    step = np.empty(n)
    for i in range(n):
        s = 0.0
        for d in range(dim):
            diff = predicted[i, d] - last[i, d]
            s += diff * diff
        step[i] = np.sqrt(s)
    return float(np.median(step))


@njit(cache=True)
def _leftovers(det_of_track: IntArray, n: int, m: int) -> tuple[IntArray, IntArray]:
    """The tracks (of the first ``n``) without a detection and the ``m`` detections no track
    took, both ascending."""
    used = np.zeros(m, dtype=np.bool_)
    n_tracks = 0
    for i in range(n):
        if det_of_track[i] >= 0:
            used[det_of_track[i]] = True
        else:
            n_tracks += 1
    tracks = np.empty(n_tracks, dtype=np.int64)
    k = 0
    for i in range(n):
        if det_of_track[i] < 0:
            tracks[k] = i
            k += 1
    dets = np.flatnonzero(~used).astype(np.int64)
    return tracks, dets


@njit(cache=True)
def _leftover_rows(
    mean: FloatArray, cov: FloatArray, z: FloatArray, tracks: IntArray, dets: IntArray, inflation: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The leftovers' rows: ``(ŷ (k, D), f S (k, D, D), z (l, D))`` with ``f = inflation``."""
    dim = mean.shape[1]
    n_tracks = tracks.shape[0]
    loose_mean = np.empty((n_tracks, dim))
    loose_cov = np.empty((n_tracks, dim, dim))
    for a in range(n_tracks):
        for d in range(dim):
            loose_mean[a, d] = mean[tracks[a], d]
            for e in range(dim):
                loose_cov[a, d, e] = cov[tracks[a], d, e] * inflation
    loose_z = np.empty((dets.shape[0], dim))
    for b in range(dets.shape[0]):
        for d in range(dim):
            loose_z[b, d] = z[dets[b], d]
    return loose_mean, loose_cov, loose_z


@njit(cache=True)
def _capped_pairs(
    ptr: IntArray,
    cols: IntArray,
    cost: FloatArray,
    loose_mean: FloatArray,
    loose_cov: FloatArray,
    loose_z: FloatArray,
    cap: float,
    clutter_log_odds: float,
) -> tuple[IntArray, IntArray, FloatArray]:
    """The pairs (compressed sparse rows) within ``cap`` of their track and, with clutter, at or
    below the track's bound ``2κ − ln|f S_i|``
    ([`recovery_costs`][agents.tracking._upkeep_kernels.recovery_costs])."""
    n_tracks, dim = loose_mean.shape
    cap2 = cap * cap
    out_ptr = np.zeros(n_tracks + 1, dtype=np.int64)
    out_cols = np.empty(cols.shape[0], dtype=np.int64)
    out_cost = np.empty(cols.shape[0])
    t = 0
    for a in range(n_tracks):
        # the largest inflated cost at which the track beats clutter (inf: no clutter)
        bound = np.inf
        if clutter_log_odds < np.inf and ptr[a + 1] > ptr[a]:
            bound = 2.0 * clutter_log_odds - log_det(loose_cov[a])
        for e in range(ptr[a], ptr[a + 1]):
            b = cols[e]
            dist2 = 0.0
            for d in range(dim):
                diff = loose_z[b, d] - loose_mean[a, d]
                dist2 += diff * diff
            if not (dist2 > cap2 or cost[e] > bound):
                out_cols[t] = b
                out_cost[t] = cost[e]
                t += 1
        out_ptr[a + 1] = t
    return out_ptr, out_cols[:t], out_cost[:t]


@njit(cache=True)
def recovery_costs(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    det_of_track: IntArray,
    inflation: float,
    gate: float,
    last: FloatArray,
    flow_step: float,
    cap_motion: float,
    cap_noise: float,
    clutter_log_odds: float = np.inf,
) -> RecoveryCosts:
    """The admissible pairs of the second-chance association of the tracks and detections left over.

    For the unassigned tracks ``i`` and the untaken detections ``j``, with the predicted
    covariance scaled by ``f = inflation``, a pair is admissible when

    .. math::

        c_{ij} = (z_j - ŷ_i)^\\top (f S_i)^{-1} (z_j - ŷ_i) \\le γ
        \\quad\\text{and}\\quad \\lVert z_j - ŷ_i \\rVert \\le r, \\qquad
        r = k_u \\max(u_{flow}, \\operatorname{median}_t \\lVert ŷ_t - x̂_t \\rVert) + r_σ,

    which bounds the jump in distance whatever the covariance (``γ = gate``; ``u_flow =
    flow_step``, the flow's motion per frame; the median runs over all live tracks ``t``, ``last``
    holding their previous estimates ``x̂_t``; ``k_u = cap_motion``, ``r_σ = cap_noise``). The cap
    is only computed when some pair passes the inflated gate.

    The pairs passing the inflated gate come from the spatial index, never a (k, l) array
    ([`agents.tracking._kernels.gated_pairs`][agents.tracking._kernels.gated_pairs] on the leftovers with
    covariances ``f S_i``:
    the box ``sqrt(γ f S_kk)`` around each leftover track, then the exact test with the dense
    expressions); the cap and the clutter test then filter that list.

    With clutter (``clutter_log_odds = κ`` finite,
    [`clutter_log_odds`][agents.tracking._upkeep_kernels.clutter_log_odds]), a pair is also refused unless the
    track's target, detected outside its gate and spread by the inflated covariance, explains the detection
    better than a miss and a clutter detection do:

    .. math::

        c_{ij} \\le 2κ - \\ln\\lvert f S_i \\rvert
        \\iff (p_D - a) \\, N(z_j; ŷ_i, f S_i) \\ge (1 - p_D) \\, λ ;

    ``κ = +inf`` (no clutter, or ``p_D = 1``) skips the test.

    Returns:
        [`RecoveryCosts`][agents.tracking._upkeep_kernels.RecoveryCosts]
            ``(tracks, dets, ptr, cols, cost, n_admissible, bad, wide, cap)``:
            the leftover tracks and detections (ascending), their admissible pairs (``cols`` index
            ``dets``), their number, ``bad`` (−1, or a leftover track whose covariance is not positive
            definite), ``wide`` (−1, or a leftover track whose inflated gate is unbounded) and the cap
            ``r`` (inf when not computed).
    """
    tracks, dets = _leftovers(det_of_track, mean.shape[0], z.shape[0])
    loose_mean, loose_cov, loose_z = _leftover_rows(mean, cov, z, tracks, dets, inflation)
    pairs = gated_pairs(loose_mean, loose_cov, loose_z, gate)
    if pairs.bad >= 0 or pairs.wide >= 0:
        bad = int(tracks[pairs.bad]) if pairs.bad >= 0 else -1
        wide = int(tracks[pairs.wide]) if pairs.wide >= 0 else -1
        return RecoveryCosts(tracks, dets, pairs.ptr, pairs.cols, pairs.cost, 0, bad, wide, np.inf)
    if pairs.cost.shape[0] == 0:
        return RecoveryCosts(tracks, dets, pairs.ptr, pairs.cols, pairs.cost, 0, -1, -1, np.inf)
    cap = cap_motion * max(flow_step, median_displacement(mean, last)) + cap_noise
    ptr, cols, cost = _capped_pairs(
        pairs.ptr, pairs.cols, pairs.cost, loose_mean, loose_cov, loose_z, cap, clutter_log_odds
    )
    return RecoveryCosts(tracks, dets, ptr, cols, cost, cost.shape[0], -1, -1, cap)


def clutter_log_odds(
    p_detect: float, clutter_density: float, hit_rate: float, p_gate: float, dim: int
) -> float:
    """``κ``, the log odds of the second chance's clutter test
    ([`recovery_costs`][agents.tracking._upkeep_kernels.recovery_costs]).

    A track left without a detection in its χ² gate has either not been detected, or been
    detected outside its gate (a kick, a velocity that was off: what the second chance is for).
    With ``a`` the probability that a track finds its detection in its gate (``hit_rate``, the
    rate measured on established tracks), the two have the odds ``(p_D − a) : (1 − p_D)``.
    A leftover detection ``z`` is either the target's, spread as the inflated prediction
    ``N(ŷ, f S)``, or clutter of density ``λ``; the second chance takes the pair when

    .. math::

        (p_D - a) \\, N(z; ŷ, f S) \\ge (1 - p_D) \\, λ
        \\iff (z - ŷ)^\\top (f S)^{-1} (z - ŷ) \\le 2κ - \\ln\\lvert f S \\rvert,
        \\qquad κ = \\ln \\frac{p_D - a}{(1 - p_D) \\, λ} - \\frac{D}{2} \\ln 2π .

    ``p_D − a`` is kept at least ``p_D (1 − P_G)``, the share of detections the gate misses
    when the motion model holds. ``+inf`` (every pair passes) without clutter (``λ = 0``) or
    without misses (``p_D = 1``: a leftover track's target was detected elsewhere); ``−inf``
    (none passes) with ``p_D = 0``.
    """
    if clutter_density <= 0.0 or p_detect >= 1.0:
        return np.inf
    if p_detect <= 0.0:
        return -np.inf
    outside = max(p_detect - hit_rate, p_detect * (1.0 - p_gate))
    return float(np.log(outside / ((1.0 - p_detect) * clutter_density)) - 0.5 * dim * np.log(2.0 * np.pi))


@njit(cache=True)
def log_det(cov: FloatArray) -> float:
    """``ln |S|`` of a symmetric positive definite ``S`` (D, D), by its Cholesky factor; ``+inf``
    when it is not positive definite (so that the clutter bound refuses the track's pairs)."""
    dim = cov.shape[0]
    low = np.zeros((dim, dim))
    if not cholesky_lower(cov, low):
        return np.inf
    total = 0.0
    for i in range(dim):
        total += 2.0 * np.log(low[i, i])
    return total


@njit(cache=True)
def survivors_and_births(
    keep: BoolArray,
    n_keep: int,
    ids: IntArray,
    misses: IntArray,
    streak: IntArray,
    estimate: FloatArray,
    detection_rows: IntArray,
    z_new: FloatArray,
    rows_new: IntArray,
    next_id: int,
) -> TrackArrays:
    """The per-track arrays of the kept tracks followed by the ``k`` new tracks born at ``z_new``.

    New tracks get ids ``next_id, next_id + 1, ...``, no misses, a streak of 1, their detection
    as estimate and ``rows_new`` as detection rows.

    Returns:
        [`TrackArrays`][agents.tracking._upkeep_kernels.TrackArrays]
            ``(ids, misses, streak, estimate, detection_rows)`` of the ``n_keep + k`` tracks.
    """
    k = z_new.shape[0]
    dim = estimate.shape[1]
    total = n_keep + k
    ids_out = np.empty(total, dtype=np.int64)
    misses_out = np.empty(total, dtype=np.int64)
    streak_out = np.empty(total, dtype=np.int64)
    est_out = np.empty((total, dim))
    rows_out = np.empty(total, dtype=np.int64)
    t = 0
    for i in range(keep.shape[0]):
        if keep[i]:
            ids_out[t] = ids[i]
            misses_out[t] = misses[i]
            streak_out[t] = streak[i]
            for d in range(dim):
                est_out[t, d] = estimate[i, d]
            rows_out[t] = detection_rows[i]
            t += 1
    for b in range(k):
        ids_out[t] = next_id + b
        misses_out[t] = 0
        streak_out[t] = 1
        for d in range(dim):
            est_out[t, d] = z_new[b, d]
        rows_out[t] = rows_new[b]
        t += 1
    return TrackArrays(ids_out, misses_out, streak_out, est_out, rows_out)
