r"""Exact marginals of a weighted bipartite matching distribution, batched over clusters.

Rows ``r < K`` and columns ``c < C`` with log weights ``L[r, c]`` (a pair), ``u[r]`` (row left
unmatched) and ``v[c]`` (column left unmatched). A matching ``M`` (each row and column used at
most once) has weight

.. math::

    w(M) = \prod_{(r,c) \in M} e^{L_{rc}} \prod_{r \notin M} e^{u_r} \prod_{c \notin M} e^{v_c},

and the marginals are ``P[r, c] = Σ_{M ∋ (r,c)} w(M) / Z``, ``Pu[r]``, ``Pv[c]`` likewise for an
unmatched row or column, ``Z = Σ_M w(M)``. JPDA is the case rows = tracks, columns =
detections, ``u = log(1 − p_D P_G)``, ``v = 0`` (or transposed, whichever side is smaller).

Dynamic programming over the columns with the set ``A ⊆ {0..K-1}`` of rows already used as a
bitmask (the subset recursion of Ryser-type permanent algorithms; the exact alternative to
enumerating events, as in the efficient hypothesis management of Maskell, Briers, Wright: Fast
mutual exclusion, 2004). Forward sums over the columns before ``c``:

.. math::

    F_0(A) = [A = ∅], \quad
    F_{c+1}(A) = F_c(A)\, e^{v_c} + \sum_{r \in A} F_c(A \setminus r)\, e^{L_{rc}},

backward sums over the columns from ``c`` on, rows outside ``A`` closing with ``e^{u_r}``:

.. math::

    G_C(A) = \prod_{r \notin A} e^{u_r}, \quad
    G_c(A) = e^{v_c} G_{c+1}(A) + \sum_{r \notin A} e^{L_{rc}} G_{c+1}(A \cup r),

so ``Z = G_0(∅)`` and

.. math::

    P[r,c] = \frac{1}{Z}\sum_{A \not\ni r} F_c(A)\, e^{L_{rc}}\, G_{c+1}(A \cup r),\quad
    Pv[c] = \frac{1}{Z}\sum_A F_c(A)\, e^{v_c} G_{c+1}(A),\quad
    Pu[r] = \frac{1}{Z}\sum_{A \not\ni r} F_C(A)\, G_C(A).

Cost ``O(C · K · 2^K)`` time and ``O(C · 2^K)`` memory per cluster, vectorised over the masks,
the rows and a batch of clusters of equal ``K`` (only the column count is padded: a padded
column has ``L = -∞``, ``v = 0`` and changes nothing). Everything is in log space
(log-sum-exp), after subtracting each row's and then each column's largest log weight (every
matching has exactly one factor per row and per column, so these shifts cancel in ``P``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def logsumexp(x: FloatArray, axis: int) -> FloatArray:
    """``log Σ exp(x)`` along ``axis``; ``-inf`` where every term is ``-inf`` (no warning)."""
    top = np.max(x, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(x - top), axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis)


@lru_cache(maxsize=32)
def _mask_tables(k: int) -> tuple[IntArray, IntArray]:
    """(k, 2^(k-1)) masks without row ``r`` and the same masks with ``r`` added."""
    masks = np.arange(1 << k, dtype=np.intp)
    without = np.stack([masks[(masks >> r) & 1 == 0] for r in range(k)]) if k else masks[:0, None]
    with_r = without | (np.intp(1) << np.arange(k, dtype=np.intp))[:, None]
    return without, with_r


def _shifted(L: FloatArray, u: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Subtract each row's, then each column's, largest finite log weight (cancels in P)."""
    row = np.maximum(np.max(L, axis=2, initial=-np.inf), u)
    row = np.where(np.isfinite(row), row, 0.0)
    L = L - row[:, :, None]
    u = u - row
    col = np.maximum(np.max(L, axis=1, initial=-np.inf), v)
    col = np.where(np.isfinite(col), col, 0.0)
    return L - col[:, None, :], u, v - col


def exact_marginals(
    L: FloatArray, u: FloatArray, v: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Exact ``P`` (B, K, C), ``Pu`` (B, K), ``Pv`` (B, C) and ``log Z`` (B,) of the module docstring.

    Args:
        L: (B, K, C) pair log weights, ``-inf`` for impossible pairs.
        u: (B, K) unmatched-row log weights.
        v: (B, C) unmatched-column log weights.

    ``log Z`` is of the shifted weights; where it is ``-inf`` (no matching has positive weight)
    the marginals are NaN and the caller reports it.
    """
    B, K, C = L.shape
    L, u, v = _shifted(L, u, v)
    without, with_r = _mask_tables(K)
    n_masks = 1 << K
    rows = np.arange(K)[:, None]
    F = np.full((C + 1, B, n_masks), -np.inf)
    F[0, :, 0] = 0.0
    G = np.empty((C + 1, B, n_masks))
    # G_C(A) = Σ_{r ∉ A} u_r: bit r of A clear adds u_r.
    masks = np.arange(n_masks)
    clear = ((masks[None, :] >> np.arange(K)[:, None]) & 1) == 0  # (K, 2^K)
    G[C] = np.where(clear[None], u[:, :, None], 0.0).sum(axis=1)
    terms = np.full((B, K + 1, n_masks), -np.inf)
    for c in range(C):
        terms.fill(-np.inf)
        terms[:, K, :] = F[c] + v[:, c, None]
        terms[:, rows, with_r] = F[c][:, without] + L[:, :, c, None]
        F[c + 1] = np.logaddexp.reduce(terms, axis=1)
    for c in range(C - 1, -1, -1):
        terms.fill(-np.inf)
        terms[:, K, :] = G[c + 1] + v[:, c, None]
        terms[:, rows, without] = G[c + 1][:, with_r] + L[:, :, c, None]
        G[c] = np.logaddexp.reduce(terms, axis=1)
    log_z = G[0][:, 0]
    with np.errstate(invalid="ignore"):
        pair = (
            np.stack([logsumexp(F[c][:, without] + G[c + 1][:, with_r], axis=2) for c in range(C)], axis=2)
            if C
            else np.zeros((B, K, 0))
        )
        P = np.exp(pair + L - log_z[:, None, None])
        Pv = np.exp(logsumexp(F[:C] + G[1:], axis=2).T + v - log_z[:, None]) if C else np.zeros((B, 0))
        end = F[C] + G[C]
        Pu = np.exp(logsumexp(end[:, without], axis=2) - log_z[:, None]) if K else np.zeros((B, 0))
    return P, Pu, Pv, log_z
