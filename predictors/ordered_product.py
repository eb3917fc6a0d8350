"""Matrix products whose every element is summed in a fixed order, on one or more threads.

``out = a b`` with ``out_ij = (…((a_i0 b_0j) + a_i1 b_1j) + …) + a_i,K−1 b_K−1,j`` in float32 (no
fused multiply-add). A BLAS GEMM sums in an order that depends on the shapes (its blocking, its
kernels for the edges, whether the product is transposed), so an element's bits change with how
many other rows or columns are computed with it. Here they do not: a row computed alone, in a
batch, in the transposed layout or on another thread gives the same bits. That is what lets the
SMC pose tracker compute the LSTM once per distinct window prefix and get the bits of computing
every particle's window ([`predictors.pose_lstm.prefix_tree`][predictors.pose_lstm.prefix_tree]).

The compiled loops (numba, GIL released) run along a row of ``b`` and ``out`` (vectorised without
reordering any sum). With ``threads > 1`` the rows of ``out`` are split into contiguous ranges,
one per thread: the calling thread computes the first, threads of a shared pool the others; a
product too small to pay for the hand-off runs on the calling thread alone. (A numba ``prange``
over the rows on the OpenMP layer lost 4-8x on a 2-core machine whose other core was busy, where
a spinning, descheduled worker stalls every product; the pool's threads wait on futures instead.)
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


@njit(cache=True, nogil=True)
def _dropout_rows(
    a: np.ndarray,
    rows: np.ndarray,
    fields: np.ndarray,
    threshold: int,
    w: np.ndarray,
    out: np.ndarray,
    start: int,
    stop: int,
) -> None:
    """Rows ``start … stop − 1`` of ``out_i = Σ_k [fields_ik < threshold] a_{rows_i, k} w_k`` (every
    field kept if ``fields`` has no rows), each element summed in the order of ``k``; a dropped term
    adds ``+0``, which leaves every sum's bits as they are (a sum starts at ``+0`` and is never
    ``−0``), so this is [`_masked_rows`][predictors.ordered_product._masked_rows] with the mask
    ``[fields < threshold]``."""
    n_out, k_dim = out.shape[1], a.shape[1]
    masked = fields.shape[0] > 0
    zero = np.float32(0.0)
    if n_out == 4:  # the pose head (μ, log σ): four sums in registers
        for i in range(start, stop):
            r = rows[i]
            o0 = o1 = o2 = o3 = zero
            for k in range(k_dim):
                v = a[r, k]
                if masked and fields[i, k] >= threshold:
                    v = zero
                o0 += v * w[k, 0]
                o1 += v * w[k, 1]
                o2 += v * w[k, 2]
                o3 += v * w[k, 3]
            out[i, 0], out[i, 1], out[i, 2], out[i, 3] = o0, o1, o2, o3
        return
    for i in range(start, stop):
        r = rows[i]
        for j in range(n_out):
            out[i, j] = zero
        for k in range(k_dim):
            v = a[r, k]
            if masked and fields[i, k] >= threshold:
                v = zero
            for j in range(n_out):
                out[i, j] += v * w[k, j]


#: Columns of the gathered operand a [`_gathered_columns`][predictors.ordered_product._gathered_columns] block
#: holds (68 × 256 float32: 70 kB).
GATHER_BLOCK = 256


@njit(cache=True, nogil=True)
def _gathered_columns(
    x: np.ndarray,
    h_t: np.ndarray,
    parents: np.ndarray,
    w_t: np.ndarray,
    out_t: np.ndarray,
    start: int,
    stop: int,
) -> None:
    """Columns ``start … stop − 1`` of ``out_tᵀ = [x, h_tᵀ[parents], 1] w_tᵀ``, i.e. column ``i`` of
    ``out_t`` is ``w_t [x_i, h_t[:, parents_i], 1]ᵀ`` (no ``h`` terms if ``h_t`` has no columns: the
    zero state), each element summed in the order of ``k`` as
    [`_product_rows`][predictors.ordered_product._product_rows] sums ``w_t · xh``. The gathered operand ``xh``
    is built a block of [`GATHER_BLOCK`][predictors.ordered_product.GATHER_BLOCK] columns at a time."""
    n_in, G = x.shape[1], w_t.shape[0]
    H = h_t.shape[0]
    from_zero = h_t.shape[1] == 0
    K = n_in + 1 if from_zero else n_in + H + 1
    xh = np.empty((K, GATHER_BLOCK), np.float32)
    K4 = K - K % 4
    for s in range(start, stop, GATHER_BLOCK):
        e = min(s + GATHER_BLOCK, stop)
        width = e - s
        for j in range(width):
            for k in range(n_in):
                xh[k, j] = x[s + j, k]
            xh[K - 1, j] = 1.0
        if not from_zero:
            for k in range(H):
                row = h_t[k]
                for j in range(width):
                    xh[n_in + k, j] = row[parents[s + j]]
        for i in range(G):
            o = out_t[i, s:e]
            for j in range(width):
                o[j] = 0.0
            for k in range(0, K4, 4):
                v0 = w_t[i, _weight_col(k, n_in, H, from_zero)]
                v1 = w_t[i, _weight_col(k + 1, n_in, H, from_zero)]
                v2 = w_t[i, _weight_col(k + 2, n_in, H, from_zero)]
                v3 = w_t[i, _weight_col(k + 3, n_in, H, from_zero)]
                b0, b1, b2, b3 = xh[k], xh[k + 1], xh[k + 2], xh[k + 3]
                for j in range(width):
                    o[j] = (((o[j] + v0 * b0[j]) + v1 * b1[j]) + v2 * b2[j]) + v3 * b3[j]
            for k in range(K4, K):
                v, bk = w_t[i, _weight_col(k, n_in, H, from_zero)], xh[k]
                for j in range(width):
                    o[j] += v * bk[j]


@njit(cache=True, inline="always")
def _weight_col(k: int, n_in: int, H: int, from_zero: bool) -> int:
    """The column of ``w_t`` that multiplies row ``k`` of the gathered operand (from the zero state
    the operand is ``[x, 1]``: its last row takes the bias column ``n_in + H``)."""
    if from_zero and k >= n_in:
        return n_in + H
    return k


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
    ranges = list(itertools.pairwise(edges))
    futures = [pool.submit(kernel, *args, s, e) for s, e in ranges[1:]]
    kernel(*args, *ranges[0])  # the first range on the calling thread: one hand-off fewer
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


def gathered_product(
    x: NDArray[np.float32],
    h_t: NDArray[np.float32],
    parents: NDArray[np.intp],
    w_t: NDArray[np.float32],
    out_t: NDArray[np.float32],
    threads: int = 1,
) -> NDArray[np.float32]:
    """``out_t[:, i] = w_t [x_i, h_t[:, parents_i], 1]ᵀ`` for every column ``i`` (``x`` (m, In), ``h_t``
    (H, U) states by column, or (H, 0) for the zero state, ``parents`` (m,), ``w_t`` (n, In + H + 1),
    ``out_t`` (n, m)), each element summed in the order of ``k`` as
    [`ordered_product`][predictors.ordered_product.ordered_product] sums ``w_t · [x, h, 1]ᵀ`` (the zero
    state's terms left out, as adding ``+0`` leaves a sum's bits): an LSTM step's transposed pre-activation
    from gathered parent states, in blocks of columns.

    Raises:
        ValueError: shapes that do not fit together.
    """
    m, n_in = x.shape
    H = h_t.shape[0]
    if (
        w_t.shape[1] != n_in + H + 1
        or out_t.shape != (w_t.shape[0], m)
        or (h_t.shape[1] and parents.shape != (m,))
    ):
        raise ValueError(
            f"gathered_product needs x (m, In), h_t (H, U), parents (m,), w_t (n, In + H + 1), out_t (n, m); "
            f"got {x.shape}, {h_t.shape}, {parents.shape}, {w_t.shape}, {out_t.shape}"
        )
    _split(_gathered_columns, m, m * w_t.shape[0] * w_t.shape[1], threads, x, h_t, parents, w_t, out_t)
    return out_t


def masked_rows_product(
    a: NDArray[np.float32],
    rows: NDArray[np.intp],
    mask: NDArray[np.float32],
    w: NDArray[np.float32],
    out: NDArray[np.float32],
    threads: int = 1,
) -> NDArray[np.float32]:
    """``out_i = (a_{rows_i} ⊙ mask_i) w`` for every result row ``i``, summed as
    [`ordered_product`][predictors.ordered_product.ordered_product] sums (``mask`` (m, k), or (0, k) for
    none): a dropout layer and the linear layer after it over gathered rows, without materialising the (m, k)
    gathered and masked rows.

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


def dropout_rows_product(
    a: NDArray[np.float32],
    rows: NDArray[np.intp],
    fields: NDArray[np.uint16],
    threshold: int,
    w: NDArray[np.float32],
    out: NDArray[np.float32],
    threads: int = 1,
) -> NDArray[np.float32]:
    """``out_i = (a_{rows_i} ⊙ [fields_i < threshold]) w`` for every result row ``i``, summed as
    [`ordered_product`][predictors.ordered_product.ordered_product] sums:
    [`masked_rows_product`][predictors.ordered_product.masked_rows_product] with a 0/1 mask given as 16-bit
    random fields (``fields`` (m, k) uint16, or (0, k) for none) and a threshold in ``0 … 2¹⁶``; the inverted
    dropout's scale ``1 / keep`` is folded into ``a`` by the caller.

    Raises:
        ValueError: shapes that do not fit together, or a threshold outside ``0 … 65536``.
    """
    m, k = len(rows), a.shape[1]
    if w.shape[0] != k or out.shape != (m, w.shape[1]) or fields.shape not in ((m, k), (0, k)):
        raise ValueError(
            f"dropout_rows_product needs a (U, k), rows (m,), fields (m, k) or (0, k), w (k, n), "
            f"out (m, n); got {a.shape}, {rows.shape}, {fields.shape}, {w.shape}, {out.shape}"
        )
    if not 0 <= threshold <= 1 << 16:
        raise ValueError(f"threshold must be in 0 … 65536, got {threshold!r}")
    _split(_dropout_rows, m, m * k * w.shape[1], threads, a, rows, fields, int(threshold), w, out)
    return out
