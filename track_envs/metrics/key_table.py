"""KeyTable: a growable hash table of int64 key pairs with int64 payload columns, for numba kernels.

Streaming metrics keep per-id and per-pair state across frames (the last track a truth was matched
to, how often a truth and a track co-occurred, which particles a track held). A Python ``dict``
keyed per object would mean per-object Python work in every frame; this table lives in two numpy
arrays that compiled kernels read and update directly:

* ``entries`` (capacity, 2 + n_values) int64, in insertion order: columns 0 and 1 hold the key
  ``(a, b)`` (single keys use ``b = 0``), the rest the payload (zero when the entry is added);
* ``index`` (n_slots + 1,) int64: an open-addressing (linear probing) hash index, ``n_slots`` a
  power of two ≥ 2 · capacity (load ≤ ½), each slot an entry number or −1; the extra last
  element holds the number of entries.

Kernels never grow the table: they check [`free_entries`][track_envs.metrics.key_table.free_entries] first,
and the Python side calls [`KeyTable.reserve`][track_envs.metrics.key_table.KeyTable.reserve] (amortised
doubling) before handing the arrays over.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit

# 64-bit odd multipliers as int64: the golden ratio 0x9E3779B97F4A7C15 and splitmix64's
# 0xBF58476D1CE4E5B9 and 0x94D049BB133111EB
_MULT_A = -7046029254386353131
_MULT_B = -4658895280553007687
_MULT_C = -7723592293110705685


@njit(cache=True)
def hash_slot(a: int, b: int, mask: int) -> int:
    """Home slot of key ``(a, b)`` among ``mask + 1`` slots (a power of two).

    The two keys are combined multiplicatively and mixed with a splitmix64-style finaliser (int64
    arithmetic wraps), so ids sharing their low bits still spread over the slots.
    """
    h = a * _MULT_A + b * _MULT_B
    h ^= h >> 32
    h *= _MULT_C
    h ^= h >> 29
    return h & mask


@njit(cache=True)
def free_entries(index: NDArray[np.int64], entries: NDArray[np.int64]) -> int:
    """How many more entries fit before the table must grow."""
    return len(entries) - index[len(index) - 1]


@njit(cache=True)
def find_entry(index: NDArray[np.int64], entries: NDArray[np.int64], a: int, b: int) -> int:
    """Entry number of key ``(a, b)``, or −1 when absent."""
    mask = len(index) - 2
    s = hash_slot(a, b, mask)
    while True:
        e = index[s]
        if e < 0:
            return -1
        if entries[e, 0] == a and entries[e, 1] == b:
            return e
        s = (s + 1) & mask


@njit(cache=True)
def add_entry(index: NDArray[np.int64], entries: NDArray[np.int64], a: int, b: int) -> int:
    """Entry number of key ``(a, b)``, adding it (payload zero) when absent; needs a free entry."""
    mask = len(index) - 2
    s = hash_slot(a, b, mask)
    while True:
        e = index[s]
        if e < 0:
            e = index[mask + 1]
            index[mask + 1] = e + 1
            index[s] = e
            entries[e, 0] = a
            entries[e, 1] = b
            entries[e, 2:] = 0
            return e
        if entries[e, 0] == a and entries[e, 1] == b:
            return e
        s = (s + 1) & mask


@njit(cache=True)
def _rebuild_index(entries: NDArray[np.int64], size: int, n_slots: int) -> NDArray[np.int64]:
    index = np.full(n_slots + 1, -1, dtype=np.int64)
    index[n_slots] = size
    mask = n_slots - 1
    for e in range(size):
        s = hash_slot(entries[e, 0], entries[e, 1], mask)
        while index[s] >= 0:
            s = (s + 1) & mask
        index[s] = e
    return index


class KeyTable:
    """A hash table of int64 key pairs ``(a, b)`` with ``n_values`` int64 payload columns.

    Args:
        n_values: Payload columns per entry.
        capacity: Entries before the first growth (rounded up to a power of two, at least 2).
    """

    def __init__(self, n_values: int, capacity: int = 256) -> None:
        if n_values < 0:
            raise ValueError(f"KeyTable n_values must be >= 0, got {n_values!r}")
        capacity = 1 << max(int(capacity) - 1, 1).bit_length()
        self.entries = np.zeros((capacity, 2 + n_values), dtype=np.int64)
        self.index = np.full(2 * capacity + 1, -1, dtype=np.int64)
        self.index[-1] = 0

    def __len__(self) -> int:
        return int(self.index[-1])

    def reserve(self, extra: int) -> None:
        """Make room for ``extra`` more entries (doubling the capacity as often as needed)."""
        need = len(self) + int(extra)
        capacity = len(self.entries)
        if need <= capacity:
            return
        while capacity < need:
            capacity *= 2
        grown = np.zeros((capacity, self.entries.shape[1]), dtype=np.int64)
        grown[: len(self)] = self.entries[: len(self)]
        self.entries = grown
        self.index = _rebuild_index(grown, len(self), 2 * capacity)

    def stored_keys(self) -> NDArray[np.int64]:
        """The keys (size, 2) in insertion order (a view)."""
        return self.entries[: len(self), :2]

    def stored_values(self) -> NDArray[np.int64]:
        """The payload (size, n_values) in insertion order (a view)."""
        return self.entries[: len(self), 2:]
