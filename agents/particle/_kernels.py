"""Compiled (numba) kernels of the batched bootstrap particle filter (agents/particle/agent.py).

For a displacement model that moves every particle of target ``t`` by one common displacement
``d_t`` plus white noise of std ``s_t``, a frame of
[`agents.particle.agent.BatchParticleFilter`][agents.particle.agent.BatchParticleFilter] is a few single
passes over the (T, N) particles instead of the numpy path's many temporaries:

1. **predict** ([`predict_common`][agents.particle._kernels.predict_common]):
``x⁽ⁱ⁾ ← x⁽ⁱ⁾ + s_t·ε⁽ⁱ⁾ + d_t``, ``ε⁽ⁱ⁾ ~ N(0, I_2)``;
2. **update** (Eq. (4) of Jung, Schlangen, Charlish, FUSION 2019;
[`log_likelihood`][agents.particle._kernels.log_likelihood], numpy's
   vectorised ``exp``, [`update_rows`][agents.particle._kernels.update_rows]):
   ``w⁽ⁱ⁾ ∝ w⁽ⁱ⁾ · exp(−||x⁽ⁱ⁾ − z_t||² / (2σ_m²))``, or a new cloud ``x⁽ⁱ⁾ = z_t + σ₀·ε⁽ⁱ⁾`` with ``w = 1/N``
   for a target whose filter starts this frame;
3. **estimate**: ``x*_t = Σ_i w⁽ⁱ⁾ x⁽ⁱ⁾``, in the same pass as ``N_eff = 1 / Σ_i (w⁽ⁱ⁾)²``;
4. **resample** ([`resample_rows`][agents.particle._kernels.resample_rows]): systematic resampling where
``N_eff < threshold·N``.

Every random number comes from the filter's ``np.random.Generator`` (numba draws from it exactly as
numpy does), in the numpy path's order: the prediction noise of all rows (C order of (T, N, 2)),
then the clouds of the starting rows, then one uniform per resampled row. Given the same
generator state the two paths therefore draw the same numbers; their weights and estimates agree
to rounding (sequential sums against numpy's pairwise ones).

Kernels and their results (the filter's arrays are written in place; none returns more than one
value):

* [`predict_common`][agents.particle._kernels.predict_common],
[`add_common`][agents.particle._kernels.add_common] → None: step 1, drawing the noise or given it.
* [`count_new`][agents.particle._kernels.count_new] → int: the rows that start this frame.
* [`log_likelihood`][agents.particle._kernels.log_likelihood] → None: the shifted log-likelihoods of step 2
into ``out``.
* [`update_rows`][agents.particle._kernels.update_rows] → int: steps 2–3 in place, the number of rows to
resample.
* [`resample_rows`][agents.particle._kernels.resample_rows] → None: step 4 in place;
[`systematic_indices`][agents.particle._kernels.systematic_indices] → None: the
  resampling indices of one row into ``out``.
* [`all_finite`][agents.particle._kernels.all_finite] → bool: whether a 2-D array holds only finite numbers.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit


@njit(cache=True)
def systematic_indices(weights: NDArray[np.float64], u: float, out: NDArray[np.intp]) -> None:
    """Systematic resampling of one weight vector (N,) with the uniform draw ``u`` into ``out`` (N,).

    Position ``p_k = (u + k) / N`` picks the first ``j`` with ``p_k < cumsum(w)[j]``, ``N − 1`` when
    rounding puts it beyond the last cumulative sum (filterpy's rule, bit for bit). Without the
    data-dependent branches of the sequential merge: ``n_j = #{k : p_k < cumsum_j}`` is
    ``⌈N·cumsum_j − u⌉`` corrected by one step against the exact comparison (as in
    [`agents.particle.agent.systematic_resample_batch`][agents.particle.agent.systematic_resample_batch]), and
    ``out[k] = #{j : n_j ≤ k}``.
    """
    n = weights.shape[0]
    marks = np.zeros(n + 1, np.intp)
    acc = 0.0
    for j in range(n):
        acc += weights[j]
        c = min(max(math.ceil(acc * n - u), 0), n)
        if c < n and (u + c) / n < acc:
            c += 1
        if c > 0 and (u + (c - 1)) / n >= acc:
            c -= 1
        marks[c] += 1
    j = 0
    for k in range(n):
        j += marks[k]
        out[k] = min(j, n - 1)


@njit(cache=True)
def predict_common(
    particles: NDArray[np.float64],
    displacement: NDArray[np.float64],
    std: NDArray[np.float64],
    rng: np.random.Generator,
) -> None:
    """``x⁽ⁱ⁾ ← (s_t·ε⁽ⁱ⁾ + x⁽ⁱ⁾) + d_t`` in place for particles (T, N, 2), displacement (T, 2) and std
    (1,) or (T,); ε drawn in C order (the order of ``rng.standard_normal((T, N, 2))``)."""
    n_t, n = particles.shape[0], particles.shape[1]
    for t in range(n_t):
        s = std[t] if std.shape[0] == n_t else std[0]
        dx, dy = displacement[t, 0], displacement[t, 1]
        for i in range(n):
            particles[t, i, 0] = (s * rng.standard_normal() + particles[t, i, 0]) + dx
            particles[t, i, 1] = (s * rng.standard_normal() + particles[t, i, 1]) + dy


@njit(cache=True)
def add_common(
    particles: NDArray[np.float64],
    displacement: NDArray[np.float64],
    std: NDArray[np.float64],
    noise: NDArray[np.float64],
) -> None:
    """[`predict_common`][agents.particle._kernels.predict_common] with the draws ``noise`` (T, N, 2) made
    beforehand."""
    n_t, n = particles.shape[0], particles.shape[1]
    for t in range(n_t):
        s = std[t] if std.shape[0] == n_t else std[0]
        dx, dy = displacement[t, 0], displacement[t, 1]
        for i in range(n):
            particles[t, i, 0] = (s * noise[t, i, 0] + particles[t, i, 0]) + dx
            particles[t, i, 1] = (s * noise[t, i, 1] + particles[t, i, 1]) + dy


@njit(cache=True)
def count_new(started: NDArray[np.bool_], has_z: NDArray[np.bool_]) -> int:
    """How many rows start this frame (a measurement, not started yet)."""
    n_new = 0
    for t in range(started.shape[0]):
        n_new += has_z[t] and not started[t]
    return n_new


@njit(cache=True)
def log_likelihood(
    particles: NDArray[np.float64],
    started: NDArray[np.bool_],
    z: NDArray[np.float64],
    has_z: NDArray[np.bool_],
    inv_2var: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """``out[t] = ℓ − max ℓ``, ``ℓ⁽ⁱ⁾ = −||x⁽ⁱ⁾ − z_t||² / (2σ_m²)`` (T, N), for the started rows with a
    measurement; 0 elsewhere. ``exp(out)`` is the likelihood of Eq. (4) up to a factor per row."""
    n_t, n = out.shape
    for t in range(n_t):
        if not (has_z[t] and started[t]):
            out[t] = 0.0
            continue
        zx, zy, c = z[t, 0], z[t, 1], inv_2var[t]
        top = -np.inf
        for i in range(n):
            dx = particles[t, i, 0] - zx
            dy = particles[t, i, 1] - zy
            ll = (dx * dx + dy * dy) * -c
            out[t, i] = ll
            top = max(top, ll)
        for i in range(n):
            out[t, i] -= top


@njit(cache=True)
def update_rows(
    particles: NDArray[np.float64],
    weights: NDArray[np.float64],
    started: NDArray[np.bool_],
    z: NDArray[np.float64],
    has_z: NDArray[np.bool_],
    lik: NDArray[np.float64],
    cloud: NDArray[np.float64],
    sigma_0: NDArray[np.float64],
    threshold: float,
    estimate: NDArray[np.float64],
    new: NDArray[np.bool_],
    low: NDArray[np.bool_],
) -> int:
    """Steps 2–3 and the resampling test, in place; returns the number of rows to resample.

    A started row with a measurement gets ``w ∝ w·lik`` (Eq. (4); the likelihood alone when every
    prior weight underflowed against it); a row that starts gets the cloud ``z_t + σ₀·ε``, ``w = 1/N``.

    Args:
        particles: (T, N, 2) predicted particles.
        weights: (T, N) normalised weights.
        started: (T,) whether each filter has started; set for the rows that start now.
        z: (T, 2) measurements; row ``t`` is read only where ``has_z[t]``.
        has_z: (T,) whether row ``t`` has a measurement this frame.
        lik: (T, N) likelihoods, ``exp`` of [`log_likelihood`][agents.particle._kernels.log_likelihood].
        cloud: (n_new, N, 2) standard-normal draws of the starting rows' clouds, in row order.
        sigma_0: (T,) std of a starting cloud.
        threshold: Resample where ``N_eff < threshold·N``.
        estimate: (T, 2) output, the weighted means (NaN where a filter has not started).
        new: (T,) output, the rows that started this frame.
        low: (T,) output, the rows to resample.
    """
    n_t, n = weights.shape
    k = 0
    for t in range(n_t):
        new[t] = has_z[t] and not started[t]
        if has_z[t] and started[t]:
            total = 0.0
            for i in range(n):
                w = weights[t, i] * lik[t, i]
                weights[t, i] = w
                total += w
            if not (total > 0.0 and math.isfinite(total)):
                total = 0.0
                for i in range(n):
                    weights[t, i] = lik[t, i]
                    total += lik[t, i]
            for i in range(n):
                weights[t, i] /= total
        elif new[t]:
            s0 = sigma_0[t]
            for i in range(n):
                particles[t, i, 0] = cloud[k, i, 0] * s0 + z[t, 0]
                particles[t, i, 1] = cloud[k, i, 1] * s0 + z[t, 1]
                weights[t, i] = 1.0 / n
            started[t] = True
            k += 1
    n_low = 0
    for t in range(n_t):
        low[t] = False
        if not started[t]:
            estimate[t, 0] = np.nan
            estimate[t, 1] = np.nan
            continue
        ex = 0.0
        ey = 0.0
        squares = 0.0
        for i in range(n):
            w = weights[t, i]
            ex += w * particles[t, i, 0]
            ey += w * particles[t, i, 1]
            squares += w * w
        estimate[t, 0] = ex
        estimate[t, 1] = ey
        if 1.0 / squares < threshold * n:
            low[t] = True
            n_low += 1
    return n_low


@njit(cache=True)
def resample_rows(
    particles: NDArray[np.float64],
    weights: NDArray[np.float64],
    low: NDArray[np.bool_],
    u: NDArray[np.float64],
) -> None:
    """Systematic resampling ([`systematic_indices`][agents.particle._kernels.systematic_indices]) in place of
    the rows where ``low`` (T,), the ``k``-th of them with the uniform draw ``u[k]``; their weights become
    ``1/N``."""
    n_t, n = weights.shape
    picks = np.empty(n, np.intp)
    copy = np.empty((n, 2))
    k = 0
    for t in range(n_t):
        if not low[t]:
            continue
        systematic_indices(weights[t], u[k], picks)
        k += 1
        copy[:] = particles[t]
        for i in range(n):
            particles[t, i, 0] = copy[picks[i], 0]
            particles[t, i, 1] = copy[picks[i], 1]
            weights[t, i] = 1.0 / n


@njit(cache=True)
def all_finite(values: NDArray[np.float64]) -> bool:
    """Whether every entry of a 2-D array is finite (one pass, no temporaries)."""
    for r in range(values.shape[0]):
        for c in range(values.shape[1]):
            if not math.isfinite(values[r, c]):
                return False
    return True
