"""Lone-pair splitting: the compiled split equals the numpy definition."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.assignment import lone_pairs, split_lone_pairs


@pytest.mark.parametrize("seed", range(30))
def test_split_from_counts_equals_lone_pairs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, m = rng.integers(0, 12, size=2)
    admissible = rng.random((n, m)) < rng.uniform(0.02, 0.4)
    row_count = admissible.sum(axis=1).astype(np.int64)
    col_count = admissible.sum(axis=0).astype(np.int64)
    first_col = admissible.argmax(axis=1) if m else np.zeros(n, dtype=np.int64)
    only_col = np.where(row_count == 1, first_col, 0).astype(np.int64)
    partner, rest_rows, rest_cols = split_lone_pairs(row_count, only_col, col_count)
    (rows, cols), ref_rest_rows, ref_rest_cols = lone_pairs(admissible)
    np.testing.assert_array_equal(np.flatnonzero(partner >= 0), rows)
    np.testing.assert_array_equal(partner[rows], cols)
    np.testing.assert_array_equal(rest_rows, ref_rest_rows)
    np.testing.assert_array_equal(rest_cols, ref_rest_cols)
