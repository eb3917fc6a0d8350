"""Exact prefix sharing of LSTM windows: every distinct input prefix is stepped once.

A stateless LSTM reads each window ``x_r`` (L steps) from the zero state, so its state after step
``d`` is a function of the prefix ``x_r[0..d]`` alone: windows with a common prefix compute the
same states up to where they first differ. The SMC pose tracker's windows share long prefixes —
particles that took the observation history ``s`` frames ago share all of its older steps, and
resampled copies share their ancestor's — so a prefix tree (trie) over the windows removes most
LSTM steps: on the benchmark scene of ``benchmarks/bench_pose_smc.py`` (10 people, P = 300, L = 10)
about 9,200 node steps per frame instead of 96,000 for the distinct queues and 485,000 for every
particle's window.

The tree (:class:`PrefixTree`): sort the windows lexicographically by their steps (the bits of
their float32 inputs, so equal means bit-equal); in sorted order a window starts a new node at
depth ``d`` iff its prefix ``0..d`` differs from the previous window's, i.e. it started a new node
at depth ``d − 1`` or its step ``d`` differs. Node ``j`` at depth ``d`` has one representative
window (its first in sorted order), whose step ``d`` is the node's input, and a parent, the node at
depth ``d − 1`` of that window. :meth:`PrefixTree.encode` steps the cell once per node, depth by
depth, from its parent's state; each window's output is its leaf's state. The arithmetic per node
is the arithmetic the plain pass does for each of its windows (the same cell, the same product
per column), so the outputs are the plain pass's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray


class SequenceCell(Protocol):
    """What :meth:`PrefixTree.encode` needs of a cell (:class:`predictors.lstm_cell.FusedLSTMCell`)."""

    def sequence(
        self,
        x: NDArray[np.floating],
        state: tuple[NDArray[np.floating], NDArray[np.floating]] | None = None,
        block: int = 512,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]: ...


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
        key = np.ascontiguousarray(x).view(np.int32).reshape(n, L * k)
        order = np.lexsort(key.T[::-1])  # sorted by step 0, then step 1, …
        s = key[order]
        new = np.ones((n, L), dtype=bool)  # new[i, d]: sorted window i starts a node at depth d
        step_differs = (s[1:] != s[:-1]).reshape(n - 1, L, k).any(axis=2)
        new[1:] = np.logical_or.accumulate(step_differs, axis=1)
        node = np.cumsum(new, axis=0) - 1  # node index at each depth of each sorted window
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
        from the zero state, one cell step per node."""
        state: tuple[NDArray[np.float32], NDArray[np.float32]] | None = None
        for d, (rows, parents) in enumerate(zip(self.rows, self.parents, strict=True)):
            step = x[rows, d : d + 1]
            state = cell.sequence(step, None if state is None else (state[0][parents], state[1][parents]))
        assert state is not None
        return state[0][self.leaf]
