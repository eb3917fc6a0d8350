"""Floating-point sums for numba kernels: numpy's pairwise order, and a compensated running sum.

* :func:`numpy_sum` adds the values in exactly the order of ``numpy.sum`` on a contiguous float64
  array (pairwise summation: blocks of at most 128 values summed with eight interleaved
  accumulators, combined as ``((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))``, larger arrays
  halved at a multiple of eight), so a kernel reproduces a numpy result bit for bit.
* :func:`neumaier_add` adds one value to a running sum kept as ``(sum, compensation)``
  (Neumaier's improved Kahan summation), so an episode-long sum of many small terms stays exact to
  about one rounding instead of drifting with the number of terms.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

_BLOCK = 128


@njit(cache=True)
def _block_sum(a: NDArray[np.float64], lo: int, n: int) -> float:
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def numpy_sum(a: NDArray[np.float64]) -> float:
    """``numpy.sum(a)`` of a 1-D float64 array, same additions in the same order."""
    n = len(a)
    if n <= _BLOCK:
        return _block_sum(a, 0, n)
    # numpy recurses: a range longer than a block splits at (n // 2) rounded down to a multiple
    # of 8 and returns left + right. The same tree is walked here with an explicit stack (a
    # range's stage: 0 = left half pending, 1 = right half pending, 2 = add the two halves).
    lo = np.empty(64, dtype=np.int64)
    size = np.empty(64, dtype=np.int64)
    stage = np.empty(64, dtype=np.int64)
    partial = np.empty(64)
    top, n_partial = 0, 0
    lo[0], size[0], stage[0] = 0, n, 0
    while top >= 0:
        if size[top] <= _BLOCK:
            partial[n_partial] = _block_sum(a, lo[top], size[top])
            n_partial += 1
            top -= 1
            continue
        half = size[top] // 2
        half -= half % 8
        if stage[top] == 0:
            stage[top] = 1
            lo[top + 1], size[top + 1], stage[top + 1] = lo[top], half, 0
            top += 1
        elif stage[top] == 1:
            stage[top] = 2
            lo[top + 1], size[top + 1], stage[top + 1] = lo[top] + half, size[top] - half, 0
            top += 1
        else:
            n_partial -= 1
            partial[n_partial - 1] = partial[n_partial - 1] + partial[n_partial]
            top -= 1
    return partial[0]


@njit(cache=True)
def neumaier_add(acc: NDArray[np.float64], value: float) -> None:
    """Add ``value`` to the running sum ``acc = [sum, compensation]`` (total = sum + compensation)."""
    s = acc[0]
    t = s + value
    if abs(s) >= abs(value):
        acc[1] += (s - t) + value
    else:
        acc[1] += (value - t) + s
    acc[0] = t
