"""The prefix tree of LSTM windows: its nodes, and outputs bit-equal to running every window."""

from __future__ import annotations

import numpy as np
import pytest

from predictors.lstm_cell import LSTMCellWeights
from predictors.pose_lstm.prefix_tree import PrefixTree


def _cell(hidden: int = 16, seed: int = 0):
    rng = np.random.default_rng(seed)
    H = hidden
    w = LSTMCellWeights.from_torch(
        rng.normal(0, 0.4, (4 * H, 3)),
        rng.normal(0, 0.4, (4 * H, H)),
        rng.normal(0, 0.1, 4 * H),
        rng.normal(0, 0.1, 4 * H),
    )
    return w.fused("ordered")


def _windows(n: int, L: int, seed: int) -> np.ndarray:
    """Windows that share prefixes as the tracker's do: a few trunks, branching late."""
    rng = np.random.default_rng(seed)
    trunks = rng.normal(0, 1, (4, L, 3)).astype(np.float32)
    x = trunks[rng.integers(0, 4, n)].copy()
    split = rng.integers(0, L + 1, n)  # steps from `split` on are the window's own
    own = rng.normal(0, 1, (n, L, 3)).astype(np.float32)
    late = np.arange(L)[None, :] >= split[:, None]
    x[late] = own[late]
    return x


def test_the_tree_of_a_hand_example() -> None:
    a, b, c = ([v, v, 1.0] for v in (0.1, 0.2, 0.3))
    x = np.array([[a, b, c], [a, b, a], [a, c, c], [a, b, c], [b, b, c]], np.float32)  # (5, 3, 3)
    tree = PrefixTree.of(x)
    assert [len(r) for r in tree.rows] == [2, 3, 4]  # {a, b}; {ab, ac, bb}; {aba, abc, acc, bbc}
    assert tree.nodes == 9
    leaves = tree.leaf
    assert leaves[0] == leaves[3] and len(set(leaves.tolist())) == 4
    for d in range(1, 3):  # every node's representative extends its parent's prefix
        parent_rows = tree.rows[d - 1][tree.parents[d]]
        np.testing.assert_array_equal(x[tree.rows[d], :d], x[parent_rows, :d])


@pytest.mark.parametrize("L", [1, 4, 10])
def test_encoding_the_tree_gives_the_bits_of_encoding_every_window(L: int) -> None:
    cell = _cell()
    x = _windows(700, L, seed=L)
    tree = PrefixTree.of(x)
    assert tree.nodes < 700 * L or L == 1
    np.testing.assert_array_equal(tree.encode(cell, x), cell.sequence(x)[0])


def test_the_tree_on_two_threads_gives_the_bits_of_one() -> None:
    import dataclasses

    cell = _cell(hidden=64)
    x = _windows(3000, 6, seed=3)  # depths wide enough to split between the threads
    tree = PrefixTree.of(x)
    two = dataclasses.replace(cell, threads=2)
    np.testing.assert_array_equal(tree.encode(two, x), tree.encode(cell, x))
    np.testing.assert_array_equal(tree.encode(two, x), cell.sequence(x)[0])


def test_equal_prefixes_are_compared_bit_for_bit() -> None:
    x = np.zeros((3, 2, 3), np.float32)
    x[1, 0, 0] = -0.0  # equal to 0.0 as a number, another bit pattern: its own node
    x[2, 1, 0] = 1e-30
    tree = PrefixTree.of(x)
    assert [len(r) for r in tree.rows] == [2, 3]


def test_no_windows_and_bad_windows() -> None:
    cell = _cell()
    empty = np.zeros((0, 5, 3), np.float32)
    assert PrefixTree.of(empty).encode(cell, empty).shape == (0, 16)
    with pytest.raises(ValueError, match=r"float32 \(n, L, In\) with L >= 1, got float64 \(2, 3, 3\)"):
        PrefixTree.of(np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match=r"got float32 \(2, 0, 3\)"):
        PrefixTree.of(np.zeros((2, 0, 3), np.float32))


def test_the_gathered_product_is_the_ordered_product_of_the_gathered_operand() -> None:
    from predictors.ordered_product import gathered_product, ordered_product

    rng = np.random.default_rng(5)
    n, U, H = 700, 90, 16
    x = rng.normal(0, 1, (n, 3)).astype(np.float32)
    h_t = rng.normal(0, 1, (H, U)).astype(np.float32)
    parents = rng.integers(0, U, n)
    w_t = rng.normal(0, 1, (4 * H, 3 + H + 1)).astype(np.float32)
    xh = np.concatenate([x, h_t[:, parents].T, np.ones((n, 1), np.float32)], axis=1)
    want = np.empty((4 * H, n), np.float32)
    ordered_product(w_t, np.ascontiguousarray(xh.T), want)
    for threads in (1, 2):
        got = np.empty((4 * H, n), np.float32)
        np.testing.assert_array_equal(gathered_product(x, h_t, parents, w_t, got, threads), want)
    zero = np.empty((4 * H, n), np.float32)  # from the zero state: the h terms left out, same bits
    x0 = np.concatenate([x, np.zeros((n, H), np.float32), np.ones((n, 1), np.float32)], axis=1)
    ordered_product(w_t, np.ascontiguousarray(x0.T), want)
    np.testing.assert_array_equal(gathered_product(x, np.zeros((H, 0), np.float32), parents, w_t, zero), want)
