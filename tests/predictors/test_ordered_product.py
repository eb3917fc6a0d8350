"""Products summed in a fixed order: the value of a float64 product, bits independent of the batch."""

from __future__ import annotations

import numpy as np
import pytest

from predictors.ordered_product import MIN_MACS_PER_THREAD, masked_rows_product, ordered_product


def _mats(m: int, k: int, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.normal(0, 1, (m, k)).astype(np.float32), rng.normal(0, 1, (k, n)).astype(np.float32)


def test_the_product_equals_float64_and_sums_each_element_in_order_of_k() -> None:
    a, b = _mats(7, 5, 3, 0)
    out = ordered_product(a, b, np.empty((7, 3), np.float32))
    np.testing.assert_allclose(out, a.astype(np.float64) @ b.astype(np.float64), rtol=0, atol=1e-5)
    expected = np.zeros((7, 3), np.float32)  # the documented order, one float32 rounding per term
    for k in range(5):
        expected = expected + a[:, k : k + 1] * b[k : k + 1, :]
    np.testing.assert_array_equal(out, expected)


def test_a_rows_bits_do_not_depend_on_the_batch_the_layout_or_the_threads() -> None:
    a, b = _mats(600, 68, 256, 1)  # large enough to be split over threads
    assert 2 * MIN_MACS_PER_THREAD <= 600 * 68 * 256
    full = ordered_product(a, b, np.empty((600, 256), np.float32))
    for rows in (slice(0, 1), slice(3, 10), slice(100, 517)):
        part = a[rows]
        np.testing.assert_array_equal(
            ordered_product(part, b, np.empty((len(part), 256), np.float32)), full[rows]
        )
    transposed = ordered_product(
        np.ascontiguousarray(b.T), np.ascontiguousarray(a.T), np.empty((256, 600), np.float32)
    )
    np.testing.assert_array_equal(transposed.T, full)
    np.testing.assert_array_equal(ordered_product(a, b, np.empty((600, 256), np.float32), threads=2), full)
    np.testing.assert_array_equal(ordered_product(a, b, np.empty((600, 256), np.float32), threads=3), full)


def test_the_masked_rows_product_is_gather_mask_product() -> None:
    rng = np.random.default_rng(2)
    a, w = _mats(9, 40, 4, 3)
    rows = rng.integers(0, 9, 5000)
    mask = ((rng.random((5000, 40), dtype=np.float32) < np.float32(0.7)) / np.float32(0.7)).astype(np.float32)
    expected = ordered_product(a[rows] * mask, w, np.empty((5000, 4), np.float32))
    for threads in (1, 2):
        out = masked_rows_product(a, rows, mask, w, np.empty((5000, 4), np.float32), threads)
        np.testing.assert_array_equal(out, expected)
    unmasked = masked_rows_product(a, rows, np.ones((0, 40), np.float32), w, np.empty((5000, 4), np.float32))
    np.testing.assert_array_equal(unmasked, ordered_product(a[rows], w, np.empty((5000, 4), np.float32)))


def test_bad_shapes_and_threads_are_named() -> None:
    a, b = _mats(3, 4, 2, 4)
    with pytest.raises(ValueError, match=r"\(m, K\) @ \(K, n\) -> \(m, n\), got \(3, 4\) @ \(3, 4\)"):
        ordered_product(a, a, np.empty((3, 4), np.float32))
    with pytest.raises(ValueError, match=r"threads must be >= 1, got 0"):
        ordered_product(a, b, np.empty((3, 2), np.float32), threads=0)
    with pytest.raises(ValueError, match=r"mask \(m, k\) or \(0, k\).*\(2, 4\)"):
        masked_rows_product(a, np.arange(3), np.ones((2, 4), np.float32), b, np.empty((3, 2), np.float32))
