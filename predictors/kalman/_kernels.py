"""Compiled (numba) kernels of the batched linear Kalman filter: one loop over tracks per call.

Each kernel runs the equations of [`predictors.kalman.predictor`][predictors.kalman.predictor] track by track
with explicit loops over the small matrices (``S`` state entries, ``D`` measured ones), so a frame of ``n``
tracks costs one call instead of a few dozen numpy operations on ``(n, S, S)`` stacks.

* Entries of ``F`` and ``H`` that are exactly zero are skipped (the kinematic ``F = A ⊗ I_D`` and
  ``H = [I_D, 0]`` are mostly zeros); leaving out a zero term changes no sum of finite numbers.
* Covariances are computed on their upper triangle and mirrored, so every covariance a kernel
  returns is exactly symmetric (the ``(P + Pᵀ)/2`` of the textbook formulation).
* The per-track bodies take ``S`` and ``D`` as arguments and are inlined into their kernel; the
  planar CV and CA models (``D = 2``, ``S = 4, 6``) get a copy with constant sizes, whose small
  loops the compiler unrolls (2–3x faster); every other shape runs the same code with run-time
  sizes.

Inputs are float64 C-contiguous arrays (the callers in
[`predictors.kalman.predictor`][predictors.kalman.predictor] make sure of it); the kernels allocate their
outputs and never write to their inputs.

Kernels and their results (``n`` tracks, ``S`` state entries, ``D`` measured ones):

* [`project_tracks`][predictors.kalman._kernels.project_tracks] → ``(z_mean (n, D), z_cov (n, D, D))``:
``(H x, H P Hᵀ + R)``.
* [`predict_tracks`][predictors.kalman._kernels.predict_tracks] → ``(mean (n, S), cov (n, S, S))``:
``(F x, F P Fᵀ + Q)``.
* [`predict_and_project_tracks`][predictors.kalman._kernels.predict_and_project_tracks] →
[`PredictedTracks`][predictors.kalman._kernels.PredictedTracks] ``(mean, cov, z_mean, z_cov)``:
  both of the above in one call.
* [`update_tracks`][predictors.kalman._kernels.update_tracks] →
[`UpdatedTracks`][predictors.kalman._kernels.UpdatedTracks] ``(mean, cov, status, row)``: the Joseph-form
  update of the seen tracks.
* [`mixture_update_tracks`][predictors.kalman._kernels.mixture_update_tracks] →
[`UpdatedTracks`][predictors.kalman._kernels.UpdatedTracks]: the PDA update by each track's
  measurement mixture.
* [`start_tracks`][predictors.kalman._kernels.start_tracks] → ``(mean (n, S), cov (n, S, S))``: the states of
new tracks.
* [`keep_and_start_tracks`][predictors.kalman._kernels.keep_and_start_tracks] →
[`KeptAndStarted`][predictors.kalman._kernels.KeptAndStarted] ``(mean, cov, status)``: the survivors
  followed by new tracks.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from predictors.base import Crossings
from track_envs.infra.compiled import njit
from track_envs.values.types import FloatArray

#: Status codes of [`update_tracks`][predictors.kalman._kernels.update_tracks].
UPDATE_OK = 0
UPDATE_NONFINITE_Z = 1
UPDATE_NOT_PD = 2
#: Status codes of [`keep_and_start_tracks`][predictors.kalman._kernels.keep_and_start_tracks].
START_OK = 0
START_BAD_KEEP = 1
START_NONFINITE_VELOCITY = 2


class PredictedTracks(NamedTuple):
    """Result of [`predict_and_project_tracks`][predictors.kalman._kernels.predict_and_project_tracks]: the
    predicted states and measurements.

    Attributes:
        mean: (n, S) predicted state means ``x⁻ = F x``.
        cov: (n, S, S) predicted state covariances ``P⁻ = F P Fᵀ + Q``, exactly symmetric.
        z_mean: (n, D) predicted measurements ``H x⁻``.
        z_cov: (n, D, D) innovation covariances ``H P⁻ Hᵀ + R``, exactly symmetric.
    """

    mean: FloatArray
    cov: FloatArray
    z_mean: FloatArray
    z_cov: FloatArray


class UpdatedTracks(NamedTuple):
    """Result of [`update_tracks`][predictors.kalman._kernels.update_tracks].

    Attributes:
        mean: (n, S) state means ``x⁺`` (unchanged for the tracks not seen).
        cov: (n, S, S) state covariances ``P⁺``, exactly symmetric.
        status: [`UPDATE_OK`][predictors.kalman._kernels.UPDATE_OK],
            [`UPDATE_NONFINITE_Z`][predictors.kalman._kernels.UPDATE_NONFINITE_Z] or
            [`UPDATE_NOT_PD`][predictors.kalman._kernels.UPDATE_NOT_PD] (the arrays are then not meaningful).
        row: −1, or the first offending row (a seen row of ``z`` holding NaN or inf; a seen
            track whose ``S`` is not positive definite).
    """

    mean: FloatArray
    cov: FloatArray
    status: int
    row: int


class KeptAndStarted(NamedTuple):
    """Result of [`keep_and_start_tracks`][predictors.kalman._kernels.keep_and_start_tracks]: the survivors,
    in order, then the new tracks.

    Attributes:
        mean: (n_keep + k, S) state means.
        cov: (n_keep + k, S, S) state covariances.
        status: [`START_OK`][predictors.kalman._kernels.START_OK],
            [`START_BAD_KEEP`][predictors.kalman._kernels.START_BAD_KEEP] or
            [`START_NONFINITE_VELOCITY`][predictors.kalman._kernels.START_NONFINITE_VELOCITY] (the arrays are
            then not meaningful).
    """

    mean: FloatArray
    cov: FloatArray
    status: int


@njit(inline="always")
def _map_rows(
    mean: FloatArray, cov: FloatArray, A: FloatArray, B: FloatArray,
    out_mean: FloatArray, out_cov: FloatArray, S: int, K: int,
) -> None:  # fmt: skip
    """``out_mean[t] = A x_t``, ``out_cov[t] = A P_t Aᵀ + B`` (upper triangle, mirrored) for every
    track ``t``, with ``A`` (K, S): the prediction (``A = F``, ``B = Q``, K = S) and the predicted
    measurement (``A = H``, ``B = R``, K = D). Zeros of ``A`` are skipped."""
    AP = np.empty((K, S))
    for t in range(mean.shape[0]):
        for i in range(K):
            acc = 0.0
            for j in range(S):
                AP[i, j] = 0.0
            for k in range(S):
                a = A[i, k]
                if a != 0.0:
                    acc += a * mean[t, k]
                    for j in range(S):
                        AP[i, j] += a * cov[t, k, j]
            out_mean[t, i] = acc
        # (A P Aᵀ)[i, j] = Σ_k (A P)[i, k] A[j, k]
        for i in range(K):
            for j in range(i, K):
                acc = B[i, j]
                for k in range(S):
                    a = A[j, k]
                    if a != 0.0:
                        acc += AP[i, k] * a
                out_cov[t, i, j] = acc
                out_cov[t, j, i] = acc


@njit(inline="always")
def _update_rows(
    mean: FloatArray, cov: FloatArray, z: FloatArray, seen: NDArray[np.bool_], H: FloatArray,
    R: FloatArray, mean_u: FloatArray, cov_u: FloatArray, S: int, D: int,
) -> int:  # fmt: skip
    """Joseph-form update of the seen tracks into ``mean_u``, ``cov_u`` (see
    [`update_tracks`][predictors.kalman._kernels.update_tracks]).

    Returns:
        -1, or the first seen track whose innovation covariance is not positive definite.
    """
    HP = np.empty((D, S))
    Sm = np.empty((D, D))
    L = np.zeros((D, D))
    inv_diag = np.empty(D)
    Kt = np.empty((D, S))
    W = np.empty((D, S))
    y = np.empty(D)
    for t in range(mean.shape[0]):
        if not seen[t]:
            continue
        # H P and the innovation y = z − H x
        for d in range(D):
            hx = 0.0
            for j in range(S):
                HP[d, j] = 0.0
            for k in range(S):
                h = H[d, k]
                if h != 0.0:
                    hx += h * mean[t, k]
                    for j in range(S):
                        HP[d, j] += h * cov[t, k, j]
            y[d] = z[t, d] - hx
        # S = H P Hᵀ + R, symmetrised
        for a in range(D):
            for b in range(D):
                acc = R[a, b]
                for k in range(S):
                    h = H[b, k]
                    if h != 0.0:
                        acc += HP[a, k] * h
                Sm[a, b] = acc
        for a in range(D):
            for b in range(a + 1, D):
                s = 0.5 * (Sm[a, b] + Sm[b, a])
                Sm[a, b] = s
                Sm[b, a] = s
        # S = L Lᵀ (Cholesky)
        for j in range(D):
            s = Sm[j, j]
            for k in range(j):
                s -= L[j, k] * L[j, k]
            if not s > 0.0:
                return t
            ljj = np.sqrt(s)
            L[j, j] = ljj
            inv_diag[j] = 1.0 / ljj
            for i in range(j + 1, D):
                s = Sm[i, j]
                for k in range(j):
                    s -= L[i, k] * L[j, k]
                L[i, j] = s * inv_diag[j]
        # Kᵀ = S⁻¹ H P: forward solve L V = H P, back solve Lᵀ Kᵀ = V, column by column
        for j in range(S):
            for a in range(D):
                s = HP[a, j]
                for k in range(a):
                    s -= L[a, k] * Kt[k, j]
                Kt[a, j] = s * inv_diag[a]
            for a in range(D - 1, -1, -1):
                s = Kt[a, j]
                for k in range(a + 1, D):
                    s -= L[k, a] * Kt[k, j]
                Kt[a, j] = s * inv_diag[a]
        # x⁺ = x + K y
        for i in range(S):
            acc = mean[t, i]
            for d in range(D):
                acc += Kt[d, i] * y[d]
            mean_u[t, i] = acc
        # W = ½ S Kᵀ − H P, then P⁺_ij = ½ (P_ij + P_ji) + Σ_d (Kᵀ_di W_dj + Kᵀ_dj W_di)
        for a in range(D):
            for j in range(S):
                acc = 0.0
                for b in range(D):
                    acc += Sm[a, b] * Kt[b, j]
                W[a, j] = 0.5 * acc - HP[a, j]
        for i in range(S):
            for j in range(i, S):
                acc = 0.5 * (cov[t, i, j] + cov[t, j, i])
                for d in range(D):
                    acc += Kt[d, i] * W[d, j] + Kt[d, j] * W[d, i]
                cov_u[t, i, j] = acc
                cov_u[t, j, i] = acc
    return -1


@njit(cache=True)
def project_tracks(
    mean: FloatArray, cov: FloatArray, H: FloatArray, R: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Measurement-space Gaussians of ``n`` tracks: ``(H x, H P Hᵀ + R)``.

    Args:
        mean: (n, S). cov: (n, S, S), symmetric. H: (D, S). R: (D, D), symmetric.

    Returns:
        ``(z_mean (n, D), z_cov (n, D, D))``, ``z_cov`` exactly symmetric.
    """
    n, S = mean.shape
    D = H.shape[0]
    z_mean = np.empty((n, D))
    z_cov = np.empty((n, D, D))
    if D == 2 and S == 4:
        _map_rows(mean, cov, H, R, z_mean, z_cov, 4, 2)
    elif D == 2 and S == 6:
        _map_rows(mean, cov, H, R, z_mean, z_cov, 6, 2)
    else:
        _map_rows(mean, cov, H, R, z_mean, z_cov, S, D)
    return z_mean, z_cov


@njit(cache=True)
def predict_tracks(
    mean: FloatArray, cov: FloatArray, F: FloatArray, Q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Kalman prediction of ``n`` tracks: ``x⁻ = F x``, ``P⁻ = F P Fᵀ + Q``.

    Args:
        mean: (n, S). cov: (n, S, S), symmetric. F: (S, S). Q: (S, S), symmetric.

    Returns:
        ``(x⁻ (n, S), P⁻ (n, S, S))``; ``P⁻`` is the upper triangle of ``F P Fᵀ + Q`` mirrored.
    """
    n, S = mean.shape
    mean_p = np.empty((n, S))
    cov_p = np.empty((n, S, S))
    if S == 4:
        _map_rows(mean, cov, F, Q, mean_p, cov_p, 4, 4)
    elif S == 6:
        _map_rows(mean, cov, F, Q, mean_p, cov_p, 6, 6)
    else:
        _map_rows(mean, cov, F, Q, mean_p, cov_p, S, S)
    return mean_p, cov_p


@njit(cache=True)
def predict_and_project_tracks(
    mean: FloatArray, cov: FloatArray, F: FloatArray, Q: FloatArray, H: FloatArray, R: FloatArray
) -> PredictedTracks:
    """[`predict_tracks`][predictors.kalman._kernels.predict_tracks], then
    [`project_tracks`][predictors.kalman._kernels.project_tracks] of the prediction, in one call.

    Returns:
        [`PredictedTracks`][predictors.kalman._kernels.PredictedTracks]
            ``(x⁻ (n, S), P⁻ (n, S, S), H x⁻ (n, D), H P⁻ Hᵀ + R (n, D, D))``.
    """
    mean_p, cov_p = predict_tracks(mean, cov, F, Q)
    z_mean, z_cov = project_tracks(mean_p, cov_p, H, R)
    return PredictedTracks(mean_p, cov_p, z_mean, z_cov)


@njit(cache=True)
def update_tracks(
    mean: FloatArray, cov: FloatArray, z: FloatArray, seen: NDArray[np.bool_], H: FloatArray, R: FloatArray
) -> UpdatedTracks:
    """Kalman update of the tracks with ``seen`` True by their rows of ``z`` (Joseph form).

    For each seen track

    .. math::

        y = z - H x, \\quad S = H P H^\\top + R = L L^\\top, \\quad
        K^\\top = L^{-\\top} L^{-1} H P, \\quad x^+ = x + K y,

        P^+ = P - K H P - (K H P)^\\top + K S K^\\top
            \\;(= (I - K H) P (I - K H)^\\top + K R K^\\top \\text{ for any } K),

    evaluated symmetrised on the upper triangle as
    ``P⁺_ij = ½(P_ij + P_ji) + Σ_d (K_id W_dj + K_jd W_di)`` with ``W = ½ S Kᵀ − H P``. The other
    tracks are copied unchanged; their rows of ``z`` are never read.

    Args:
        mean: (n, S). cov: (n, S, S), symmetric. z: (n, D). seen: (n,) bool. H: (D, S).
        R: (D, D), symmetric.

    Returns:
        [`UpdatedTracks`][predictors.kalman._kernels.UpdatedTracks]
            ``(x⁺ (n, S), P⁺ (n, S, S), status, row)``: status
            [`UPDATE_OK`][predictors.kalman._kernels.UPDATE_OK] (row −1), or
            [`UPDATE_NONFINITE_Z`][predictors.kalman._kernels.UPDATE_NONFINITE_Z] /
            [`UPDATE_NOT_PD`][predictors.kalman._kernels.UPDATE_NOT_PD] and the first offending ``row`` (a
            seen row of ``z`` holding NaN or inf; a seen track whose ``S`` is not positive definite), in which
            case the arrays are not meaningful.
    """
    n, S = mean.shape
    D = H.shape[0]
    mean_u = mean.copy()
    cov_u = cov.copy()
    for t in range(n):
        if seen[t]:
            for d in range(D):
                if not np.isfinite(z[t, d]):
                    return UpdatedTracks(mean_u, cov_u, UPDATE_NONFINITE_Z, t)
    if D == 2 and S == 4:
        bad = _update_rows(mean, cov, z, seen, H, R, mean_u, cov_u, 4, 2)
    elif D == 2 and S == 6:
        bad = _update_rows(mean, cov, z, seen, H, R, mean_u, cov_u, 6, 2)
    else:
        bad = _update_rows(mean, cov, z, seen, H, R, mean_u, cov_u, S, D)
    if bad >= 0:
        return UpdatedTracks(mean_u, cov_u, UPDATE_NOT_PD, bad)
    return UpdatedTracks(mean_u, cov_u, UPDATE_OK, -1)


@njit(inline="always")
def _mixture_rows(
    mean: FloatArray, cov: FloatArray, z_mean: FloatArray, z_spread: FloatArray, p_seen: FloatArray,
    H: FloatArray, R: FloatArray, mean_u: FloatArray, cov_u: FloatArray, S: int, D: int,
) -> tuple[int, int]:  # fmt: skip
    """The PDA update of [`mixture_update_tracks`][predictors.kalman._kernels.mixture_update_tracks] into
    ``mean_u``, ``cov_u``; returns the status and the offending row (−1)."""
    n = mean.shape[0]
    PHt = np.empty((S, D))
    Sm = np.empty((D, D))
    L = np.zeros((D, D))
    K = np.empty((S, D))
    M = np.empty((D, D))
    KM = np.empty((S, D))
    y = np.empty(D)
    for t in range(n):
        p = p_seen[t]
        if p <= 0.0:
            continue
        for d in range(D):
            if not np.isfinite(z_mean[t, d]):
                return UPDATE_NONFINITE_Z, t
            for e in range(D):
                if not np.isfinite(z_spread[t, d, e]):
                    return UPDATE_NONFINITE_Z, t
        for a in range(S):
            for d in range(D):
                acc = 0.0
                for k in range(S):
                    h = H[d, k]
                    if h != 0.0:
                        acc += cov[t, a, k] * h
                PHt[a, d] = acc
        for d in range(D):
            hx = 0.0
            for k in range(S):
                h = H[d, k]
                if h != 0.0:
                    hx += h * mean[t, k]
            y[d] = z_mean[t, d] - hx
            for e in range(D):
                acc = R[d, e]
                for k in range(S):
                    h = H[d, k]
                    if h != 0.0:
                        acc += h * PHt[k, e]
                Sm[d, e] = acc
        # Cholesky of S (symmetrised)
        for r in range(D):
            for c in range(r + 1):
                acc = 0.5 * (Sm[r, c] + Sm[c, r])
                for k in range(c):
                    acc -= L[r, k] * L[c, k]
                if r == c:
                    if not acc > 0.0:
                        return UPDATE_NOT_PD, t
                    L[r, r] = np.sqrt(acc)
                else:
                    L[r, c] = acc / L[c, c]
        # K = P Hᵀ S⁻¹ row by row: solve L Lᵀ kᵀ = (P Hᵀ)ᵀ_a
        for a in range(S):
            for r in range(D):
                acc = PHt[a, r]
                for k in range(r):
                    acc -= L[r, k] * K[a, k]
                K[a, r] = acc / L[r, r]
            for r in range(D - 1, -1, -1):
                acc = K[a, r]
                for k in range(r + 1, D):
                    acc -= L[k, r] * K[a, k]
                K[a, r] = acc / L[r, r]
        for a in range(S):
            acc = 0.0
            for d in range(D):
                acc += K[a, d] * y[d]
            mean_u[t, a] = mean[t, a] + p * acc
        for d in range(D):
            for e in range(D):
                M[d, e] = z_spread[t, d, e] + (1.0 - p) * y[d] * y[e] - 0.5 * (Sm[d, e] + Sm[e, d])
        for a in range(S):
            for e in range(D):
                acc = 0.0
                for d in range(D):
                    acc += K[a, d] * M[d, e]
                KM[a, e] = acc
        for a in range(S):
            for b in range(a, S):
                acc = 0.0
                for e in range(D):
                    acc += KM[a, e] * K[b, e]
                v = 0.5 * (cov[t, a, b] + cov[t, b, a]) + p * acc
                cov_u[t, a, b] = v
                cov_u[t, b, a] = v
    return UPDATE_OK, -1


@njit(cache=True)
def mixture_update_tracks(
    mean: FloatArray, cov: FloatArray, z_mean: FloatArray, z_spread: FloatArray, p_seen: FloatArray,
    H: FloatArray, R: FloatArray,
) -> UpdatedTracks:  # fmt: skip
    """PDA update of every track with ``p_seen > 0`` (see
    [`predictors.kalman.predictor.KalmanPredictor.update_mixture`][predictors.kalman.predictor.KalmanPredictor.update_mixture]):

    .. math::

        S = H P Hᵀ + R = L Lᵀ, \\quad K = P Hᵀ S^{-1}, \\quad δ = \\bar z - H x,

        x^+ = x + p K δ, \\qquad P^+ = P + p K (Σ + (1 - p) δ δ^\\top - S) K^\\top,

    on the upper triangle and mirrored. Tracks with ``p_seen = 0`` are copied unchanged.

    Returns:
        [`UpdatedTracks`][predictors.kalman._kernels.UpdatedTracks]: status
            [`UPDATE_NOT_PD`][predictors.kalman._kernels.UPDATE_NOT_PD] and the row of the first track whose
            ``S`` is not positive definite, or
            [`UPDATE_NONFINITE_Z`][predictors.kalman._kernels.UPDATE_NONFINITE_Z] for a non-finite ``z̄`` or
            ``Σ`` where ``p > 0``.
    """
    S = mean.shape[1]
    D = H.shape[0]
    mean_u = mean.copy()
    cov_u = cov.copy()
    if D == 2 and S == 4:
        status, row = _mixture_rows(mean, cov, z_mean, z_spread, p_seen, H, R, mean_u, cov_u, 4, 2)
    elif D == 2 and S == 6:
        status, row = _mixture_rows(mean, cov, z_mean, z_spread, p_seen, H, R, mean_u, cov_u, 6, 2)
    else:
        status, row = _mixture_rows(mean, cov, z_mean, z_spread, p_seen, H, R, mean_u, cov_u, S, D)
    return UpdatedTracks(mean_u, cov_u, status, row)


@njit(cache=True)
def start_tracks(
    z: FloatArray, P0: FloatArray, velocity: FloatArray, velocity_cov: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """States of ``n`` new tracks: ``x = [z, v, 0]``, ``P = P0`` with its velocity block replaced.

    Args:
        z: (n, D) first measurements.
        P0: (S, S) covariance of a new track (``blockdiag(R, σ_v² I, σ_a² I)``).
        velocity: (n, D) velocity means, or (0, D) for zeros.
        velocity_cov: (n, D, D) velocity covariances, or (0, D, D) to keep ``P0``'s block.

    Returns:
        ``(mean (n, S), cov (n, S, S))``.
    """
    n, D = z.shape
    S = P0.shape[0]
    mean = np.zeros((n, S))
    cov = np.empty((n, S, S))
    has_v = velocity.shape[0] == n and S > D
    has_vc = velocity_cov.shape[0] == n and S > D
    for t in range(n):
        for d in range(D):
            mean[t, d] = z[t, d]
            if has_v:
                mean[t, D + d] = velocity[t, d]
        for i in range(S):
            for j in range(S):
                cov[t, i, j] = P0[i, j]
        if has_vc:
            for i in range(D):
                for j in range(D):
                    cov[t, D + i, D + j] = velocity_cov[t, i, j]
    return mean, cov


@njit(cache=True)
def keep_and_start_tracks(
    mean: FloatArray,
    cov: FloatArray,
    keep: NDArray[np.bool_],
    n_keep: int,
    z: FloatArray,
    P0: FloatArray,
    velocity: FloatArray,
    velocity_cov: FloatArray,
) -> KeptAndStarted:
    """The tracks with ``keep`` True (in order), followed by new tracks at ``z``: one pass for
    ``concat([state.take(keep), start(z, ...)])``.

    Args:
        mean, cov: (n, S) and (n, S, S) states of the live tracks.
        keep: (n,) survivors; n_keep: their number.
        z, P0, velocity, velocity_cov: as in [`start_tracks`][predictors.kalman._kernels.start_tracks]
            (``velocity`` (D,) or (0,), ``velocity_cov`` (D, D) or (0, 0): the same prior for every new
            track).

    Returns:
        [`KeptAndStarted`][predictors.kalman._kernels.KeptAndStarted]
            ``(mean (n_keep + k, S), cov (n_keep + k, S, S), status)``: status
            [`START_OK`][predictors.kalman._kernels.START_OK],
            [`START_BAD_KEEP`][predictors.kalman._kernels.START_BAD_KEEP] (``keep`` does not hold ``n_keep``
            True) or [`START_NONFINITE_VELOCITY`][predictors.kalman._kernels.START_NONFINITE_VELOCITY] (the
            arrays are then not meaningful).
    """
    k, D = z.shape
    S = P0.shape[0]
    total = n_keep + k
    out_mean = np.zeros((total, S))
    out_cov = np.empty((total, S, S))
    count = 0
    for i in range(keep.shape[0]):
        count += keep[i]
    if count != n_keep:
        return KeptAndStarted(out_mean, out_cov, START_BAD_KEEP)
    for d in range(velocity.shape[0]):
        if not np.isfinite(velocity[d]):
            return KeptAndStarted(out_mean, out_cov, START_NONFINITE_VELOCITY)
    t = 0
    for i in range(keep.shape[0]):
        if keep[i]:
            out_mean[t] = mean[i]
            out_cov[t] = cov[i]
            t += 1
    has_v = velocity.shape[0] == D and S > D
    has_vc = velocity_cov.shape[0] == D and S > D
    for b in range(k):
        for d in range(D):
            out_mean[t, d] = z[b, d]
            if has_v:
                out_mean[t, D + d] = velocity[d]
        out_cov[t] = P0
        if has_vc:
            for i in range(D):
                for j in range(D):
                    out_cov[t, D + i, D + j] = velocity_cov[i, j]
        t += 1
    return KeptAndStarted(out_mean, out_cov, START_OK)


# -- nozzle-bar crossings in closed form (the LINE_ROLLOUT capability, predictors.kalman.rollout) --------
#
# For track ``i`` with state mean ``x`` and covariance ``C`` the predicted position after ``j``
# frames is ``p_j = H₂ F^j x`` and its covariance ``P_j = (H₂ F^j) C (H₂ F^j)ᵀ + H₂ B_j H₂ᵀ``
# (``B_j = Σ_{l<j} F^l Q F^{l⊤}``); both factors are precomputed per model. The kernel walks
# ``j = 1, 2, …`` until ``p_j`` is at or past the line (a crossing between ``j − 1`` and ``j``) or
# stops advancing (no crossing), and maps the interpolated position Gaussian to ``(t_c, y_c)``.


@njit(cache=True)
def _position_cov(HA: NDArray, HBH: NDArray, cov: NDArray, i: int, j: int, out: NDArray) -> None:
    """``out`` (2, 2) ``= HA[j] cov[i] HA[j]ᵀ + HBH[j]``."""
    s = cov.shape[1]
    for a in range(2):
        for b in range(2):
            acc = HBH[j, a, b]
            for u in range(s):
                if HA[j, a, u] == 0.0:
                    continue
                row = 0.0
                for w in range(s):
                    row += cov[i, u, w] * HA[j, b, w]
                acc += HA[j, a, u] * row
            out[a, b] = acc


@njit(cache=True)
def kalman_crossings_kernel(
    HA: NDArray[np.float64],
    HBH: NDArray[np.float64],
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
    line: float,
    frame: float,
    dt: float,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """``ok`` (k,), ``(t̂, ŷ)`` (k, 2) and ``Σ`` (k, 2, 2) of the crossings of ``x = line``.

    Args:
        HA: (J + 1, 2, S) the position rows of ``H F^j``.
        HBH: (J + 1, 2, 2) ``H₂ B_j H₂ᵀ``.
        mean: (k, S) state means at frame ``frame``.
        cov: (k, S, S) state covariances.
        line: ``L``.
        frame: The frame of the states.
        dt: Frame period.
    """
    k, s = mean.shape
    steps = HA.shape[0] - 1
    ok = np.zeros(k, np.bool_)
    out_mean = np.full((k, 2), np.nan)
    out_cov = np.full((k, 2, 2), np.nan)
    P0 = np.empty((2, 2))
    P1 = np.empty((2, 2))
    for i in range(k):
        x_prev, y_prev = 0.0, 0.0
        for d in range(s):
            x_prev += HA[0, 0, d] * mean[i, d]
            y_prev += HA[0, 1, d] * mean[i, d]
        for j in range(1, steps + 1):
            x, y = 0.0, 0.0
            for d in range(s):
                x += HA[j, 0, d] * mean[i, d]
                y += HA[j, 1, d] * mean[i, d]
            step = x - x_prev
            if step <= 0.0:
                break
            if x >= line:
                phi = (line - x_prev) / step
                weight = min(max(phi, 0.0), 1.0)
                _position_cov(HA, HBH, cov, i, j - 1, P0)
                _position_cov(HA, HBH, cov, i, j, P1)
                pxx = P0[0, 0] + weight * (P1[0, 0] - P0[0, 0])
                pxy = 0.5 * (P0[0, 1] + P0[1, 0] + weight * (P1[0, 1] + P1[1, 0] - P0[0, 1] - P0[1, 0]))
                pyy = P0[1, 1] + weight * (P1[1, 1] - P0[1, 1])
                vx, vy = step / dt, (y - y_prev) / dt
                # Σ = J P Jᵀ with J = [[−1/vx, 0], [−vy/vx, 1]]
                a, b = -1.0 / vx, -vy / vx
                out_cov[i, 0, 0] = a * a * pxx
                out_cov[i, 0, 1] = a * (b * pxx + pxy)
                out_cov[i, 1, 0] = out_cov[i, 0, 1]
                out_cov[i, 1, 1] = b * b * pxx + 2.0 * b * pxy + pyy
                out_mean[i, 0] = (frame + j - 1 + phi) * dt
                out_mean[i, 1] = y_prev + phi * (y - y_prev)
                ok[i] = True
                break
            x_prev, y_prev = x, y
    return Crossings(ok, out_mean, out_cov)
