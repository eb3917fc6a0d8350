"""Matrix products whose every element is summed in a fixed order, on one or more threads.

``out = a b`` with ``out_ij = (…((a_i0 b_0j) + a_i1 b_1j) + …) + a_i,K−1 b_K−1,j`` in float32 (no
fused multiply-add). A BLAS GEMM sums in an order that depends on the shapes (its blocking, its
kernels for the edges, whether the product is transposed), so an element's bits change with how
many other rows or columns are computed with it. Here they do not: a row computed alone, in a
batch, in the transposed layout or on another thread gives the same bits. That is what lets the
SMC pose tracker compute the LSTM once per distinct window prefix and get the bits of computing
every particle's window (:mod:`predictors.pose_lstm.prefix_tree`).

The compiled loops (numba, GIL released) run along a row of ``b`` and ``out`` (vectorised without
reordering any sum). With ``threads > 1`` the rows of ``out`` are split into contiguous ranges,
one per thread of a shared pool; a product too small to pay for the hand-off runs on the calling
thread. (A numba ``prange`` over the rows on the OpenMP layer lost 4-8x on a 2-core machine
whose other core was busy, where a spinning, descheduled worker stalls every product; the pool's
threads wait on futures instead.)
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit

#: Multiply-adds below which a product stays on the calling thread.
MIN_MACS_PER_THREAD = 200_000


@njit(cache=True, nogil=True)
def _product_rows(a: np.ndarray, b: np.ndarray, out: np.ndarray, start: int, stop: int) -> None:
    """Rows ``start … stop − 1`` of ``out = a b``, each element summed in the order of ``k``.

    Four terms per pass over a row of ``out`` (``o_j ← (((o_j + a_k b_kj) + a_k+1 b_k+1,j) + …)``,
    the same order as one term per pass, a quarter of the loads and stores of ``out``)."""
    k_dim, n = a.shape[1], b.shape[1]
    k4 = k_dim - k_dim % 4
    for i in range(start, stop):
        o = out[i]
        for j in range(n):
            o[j] = 0.0
        for k in range(0, k4, 4):
            v0, v1, v2, v3 = a[i, k], a[i, k + 1], a[i, k + 2], a[i, k + 3]
            b0, b1, b2, b3 = b[k], b[k + 1], b[k + 2], b[k + 3]
            for j in range(n):
                o[j] = (((o[j] + v0 * b0[j]) + v1 * b1[j]) + v2 * b2[j]) + v3 * b3[j]
        for k in range(k4, k_dim):
            v, bk = a[i, k], b[k]
            for j in range(n):
                o[j] += v * bk[j]


@njit(cache=True, nogil=True)
def _masked_rows(
    a: np.ndarray, rows: np.ndarray, mask: np.ndarray, w: np.ndarray, out: np.ndarray, start: int, stop: int
) -> None:
    """Rows ``start … stop − 1`` of ``out_i = (a_{rows_i} ⊙ mask_i) w`` (no mask if ``mask`` has no
    rows), each element summed in the order of ``k``."""
    n_out, k_dim = out.shape[1], a.shape[1]
    masked = mask.shape[0] > 0
    for i in range(start, stop):
        r = rows[i]
        for j in range(n_out):
            out[i, j] = 0.0
        for k in range(k_dim):
            v = a[r, k] * mask[i, k] if masked else a[r, k]
            for j in range(n_out):
                out[i, j] += v * w[k, j]


@functools.cache
def thread_pool(threads: int) -> ThreadPoolExecutor:
    """The shared pool of ``threads`` threads (one per thread count, made on first use)."""
    return ThreadPoolExecutor(threads, thread_name_prefix="ordered-product")


def _split(kernel: Callable[..., None], rows: int, macs: int, threads: int, *args: object) -> None:
    """Run ``kernel(*args, start, stop)`` over ``rows`` rows on up to ``threads`` threads."""
    threads = max(1, min(int(threads), rows, macs // MIN_MACS_PER_THREAD))
    if threads == 1:
        kernel(*args, 0, rows)
        return
    edges = np.linspace(0, rows, threads + 1).astype(int)
    pool = thread_pool(threads)
    futures = [pool.submit(kernel, *args, s, e) for s, e in itertools.pairwise(edges)]
    for f in futures:
        f.result()


def ordered_product(
    a: NDArray[np.float32], b: NDArray[np.float32], out: NDArray[np.float32], threads: int = 1
) -> NDArray[np.float32]:
    """``out = a b`` ((m, K) by (K, n), all float32, C-contiguous ``b`` and ``out``), every element
    summed in the order of ``k`` (module docstring), on up to ``threads`` threads.

    Raises:
        ValueError: shapes that do not chain, or ``threads`` < 1.
    """
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[0] or out.shape != (a.shape[0], b.shape[1]):
        raise ValueError(
            f"ordered_product needs (m, K) @ (K, n) -> (m, n), got {a.shape} @ {b.shape} -> {out.shape}"
        )
    if threads < 1:
        raise ValueError(f"threads must be >= 1, got {threads!r}")
    m, k = a.shape
    _split(_product_rows, m, m * k * b.shape[1], threads, a, b, out)
    return out


def masked_rows_product(
    a: NDArray[np.float32],
    rows: NDArray[np.intp],
    mask: NDArray[np.float32],
    w: NDArray[np.float32],
    out: NDArray[np.float32],
    threads: int = 1,
) -> NDArray[np.float32]:
    """``out_i = (a_{rows_i} ⊙ mask_i) w`` for every result row ``i``, summed as :func:`ordered_product`
    sums (``mask`` (m, k), or (0, k) for none): a dropout layer and the linear layer after it over
    gathered rows, without materialising the (m, k) gathered and masked rows.

    Raises:
        ValueError: shapes that do not fit together.
    """
    m, k = len(rows), a.shape[1]
    if w.shape[0] != k or out.shape != (m, w.shape[1]) or mask.shape not in ((m, k), (0, k)):
        raise ValueError(
            f"masked_rows_product needs a (U, k), rows (m,), mask (m, k) or (0, k), w (k, n), out (m, n); "
            f"got {a.shape}, {rows.shape}, {mask.shape}, {w.shape}, {out.shape}"
        )
    _split(_masked_rows, m, m * k * w.shape[1], threads, a, rows, mask, w, out)
    return out
