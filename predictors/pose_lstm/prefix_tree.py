"""Exact prefix sharing of LSTM windows: every distinct input prefix is stepped once.

A stateless LSTM reads each window ``x_r`` (L steps) from the zero state, so its state after step
``d`` is a function of the prefix ``x_r[0..d]`` alone: windows with a common prefix compute the
same states up to where they first differ. The SMC pose tracker's windows share long prefixes —
particles that took the observation history ``s`` frames ago share all of its older steps, and
resampled copies share their ancestor's — so a prefix tree (trie) over the windows removes most
LSTM steps: on the benchmark scene of ``benchmarks/bench_pose_smc.py`` (10 people, P = 300, L = 10)
about 9,200 node steps per frame instead of 96,000 for the distinct queues and 485,000 for every
particle's window.

The tree ([`PrefixTree`][predictors.pose_lstm.prefix_tree.PrefixTree]): sort the windows lexicographically by
their steps (the bits of their float32 inputs as unsigned numbers, two to a 64-bit sort key, so equal means
bit-equal); in sorted order a window starts a new node at depth ``d`` iff its prefix ``0..d`` differs from the
previous window's, i.e. it started a new node at depth ``d − 1`` or its step ``d`` differs. Node ``j`` at
depth ``d`` has one representative window (its first in sorted order), whose step ``d`` is the
node's input, and a parent, the node at depth ``d − 1`` of that window.
[`PrefixTree.encode`][predictors.pose_lstm.prefix_tree.PrefixTree.encode] steps the cell once per node, depth
by depth, from its parent's state; each window's output is its leaf's state. The arithmetic per node is the
arithmetic the plain pass does for each of its windows (the same cell, the same product per column:
[`step_gathered`][predictors.lstm_cell.FusedLSTMCell.step_gathered] reads the parents' states in place), so
the outputs are the plain pass's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit


class SequenceCell(Protocol):
    """What [`PrefixTree.encode`][predictors.pose_lstm.prefix_tree.PrefixTree.encode] needs of a cell
    ([`predictors.lstm_cell.FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell])."""

    def sequence(
        self,
        x: NDArray[np.floating],
        state: tuple[NDArray[np.floating], NDArray[np.floating]] | None = None,
        block: int = 512,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]: ...

    def step_gathered(
        self,
        x: NDArray[np.float32],
        state_t: tuple[NDArray[np.float32], NDArray[np.float32]] | None,
        parents: NDArray[np.intp],
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]: ...


@njit(cache=True, nogil=True)
def _nodes(key: np.ndarray, order: np.ndarray, k: int, new: np.ndarray, node: np.ndarray) -> None:
    """``new[i, d]``: the ``i``-th window in ``order`` starts a node at depth ``d`` (its prefix
    ``0 … d`` differs from the previous window's: it started one at ``d − 1`` or its step ``d``
    differs); ``node[i, d]``: the index of its node at depth ``d``. ``key`` (n, L · k) bits."""
    n, L = new.shape
    count = np.zeros(L, np.intp)
    for i in range(n):
        r = order[i]
        q = order[i - 1] if i > 0 else r
        differs = i == 0
        for d in range(L):
            if not differs:
                for c in range(d * k, (d + 1) * k):
                    if key[r, c] != key[q, c]:
                        differs = True
                        break
            new[i, d] = differs
            if differs:
                count[d] += 1
            node[i, d] = count[d] - 1


def _packed(key: NDArray[np.uint32]) -> NDArray[np.uint64]:
    """Consecutive pairs of ``key``'s columns (n, c) as one uint64 each (n, ⌈c / 2⌉), the first of the
    pair in the high half: the lexicographic order of the rows is that of ``key`` (as unsigned
    numbers), with half the sort keys."""
    n, c = key.shape
    if c % 2:
        key = np.concatenate([key, np.zeros((n, 1), np.uint32)], axis=1)
    high, low = key[:, 0::2].astype(np.uint64), key[:, 1::2].astype(np.uint64)
    return (high << np.uint64(32)) | low


@dataclass(frozen=True)
class PrefixTree:
    """The trie of ``n`` windows of ``L`` steps (module docstring).

    Attributes:
        rows: Per depth ``d``, the representative window (index into the input) of each node (k_d,).
        parents: Per depth ``d``, the parent node (index into depth ``d − 1``'s nodes) of each node;
            all zero at depth 0 (the zero state is the root).
        leaf: (n,) the node at the last depth of each window.
    """

    rows: tuple[NDArray[np.intp], ...]
    parents: tuple[NDArray[np.intp], ...]
    leaf: NDArray[np.intp]

    @classmethod
    def of(cls, x: NDArray[np.float32]) -> PrefixTree:
        """The trie of windows ``x`` (n, L, In) float32, prefixes compared bit for bit.

        Raises:
            ValueError: ``x`` not a float32 (n, L, In) array with ``L >= 1``.
        """
        if x.ndim != 3 or x.dtype != np.float32 or x.shape[1] < 1:
            raise ValueError(f"windows must be float32 (n, L, In) with L >= 1, got {x.dtype} {x.shape}")
        n, L, k = x.shape
        if n == 0:
            empty = np.zeros(0, np.intp)
            return cls(tuple(empty for _ in range(L)), tuple(empty for _ in range(L)), empty)
        key = np.ascontiguousarray(x).view(np.uint32).reshape(n, L * k)
        order = np.lexsort(_packed(key).T[::-1])  # sorted by step 0, then step 1, …
        new = np.empty((n, L), dtype=bool)  # new[i, d]: sorted window i starts a node at depth d
        node = np.empty((n, L), dtype=np.intp)  # node index at each depth of each sorted window
        _nodes(key, order, k, new, node)
        rows, parents = [], []
        for d in range(L):
            starts = np.flatnonzero(new[:, d])
            rows.append(order[starts])
            parents.append(node[starts, d - 1] if d else np.zeros(len(starts), np.intp))
        leaf = np.empty(n, np.intp)
        leaf[order] = node[:, L - 1]
        return cls(tuple(rows), tuple(parents), leaf)

    @property
    def nodes(self) -> int:
        """LSTM steps the tree takes: its nodes at all depths."""
        return int(sum(len(r) for r in self.rows))

    def encode(self, cell: SequenceCell, x: NDArray[np.float32]) -> NDArray[np.float32]:
        """The last output ``h`` (n, H) of every window of ``x`` (the windows the tree was built of)
        from the zero state: [`encode_nodes`][predictors.pose_lstm.prefix_tree.PrefixTree.encode_nodes] read
        at each window's [`leaf`][predictors.pose_lstm.prefix_tree.PrefixTree.leaf]."""
        return self.encode_nodes(cell, x)[self.leaf]

    def encode_nodes(self, cell: SequenceCell, x: NDArray[np.float32]) -> NDArray[np.float32]:
        """The last output ``h`` (k, H) of every node at the last depth (a distinct window of ``x``;
        window ``r``'s is row [`leaf`][predictors.pose_lstm.prefix_tree.PrefixTree.leaf] ``[r]``), one cell
        step per node
        ([`SequenceCell.step_gathered`][predictors.pose_lstm.prefix_tree.SequenceCell.step_gathered], depth by
        depth, each node from its parent's state)."""
        state_t: tuple[NDArray[np.float32], NDArray[np.float32]] | None = None  # (hᵀ, cᵀ) per node
        for d, (rows, parents) in enumerate(zip(self.rows, self.parents, strict=True)):
            state_t = cell.step_gathered(x[rows, d], state_t, parents)  # from the parents' states
        if state_t is None:
            return np.zeros((0, 0), np.float32)
        return np.ascontiguousarray(state_t[0].T)
