"""KeyTable behaves as a dict of int64 key pairs, through every growth."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from track_envs.metrics.key_table import KeyTable, add_entry, find_entry, free_entries


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 2**20, 2**40, -(2**62)]))
def test_counts_equal_a_dict_oracle_through_growth(seed, stride):
    """Keys sharing their low bits (multiples of large powers of two) and negative keys included."""
    rng = np.random.default_rng(seed)
    table, oracle = KeyTable(n_values=2, capacity=4), {}
    for _ in range(rng.integers(1, 30)):
        keys = rng.integers(-50, 50, size=(rng.integers(0, 60), 2)) * stride
        table.reserve(len(keys))
        for a, b in keys:
            e = add_entry(table.index, table.entries, a, b)
            table.entries[e, 2] += 1
            table.entries[e, 3] = a // 2 - b // 2
            oracle[(int(a), int(b))] = oracle.get((int(a), int(b)), 0) + 1
    assert len(table) == len(oracle)
    keys, values = table.stored_keys(), table.stored_values()
    assert {(int(a), int(b)): int(n) for (a, b), n in zip(keys, values[:, 0], strict=True)} == oracle
    assert [tuple(k) for k in keys] == list(oracle)  # insertion order
    assert (values[:, 1] == keys[:, 0] // 2 - keys[:, 1] // 2).all()  # payload kept through growth
    for a, b in list(oracle)[:20]:
        assert tuple(table.entries[find_entry(table.index, table.entries, a, b), :2]) == (a, b)
    assert find_entry(table.index, table.entries, 10**15 + 1, 3) == -1
    assert free_entries(table.index, table.entries) == len(table.entries) - len(oracle)


def test_reserve_keeps_room_and_rejects_bad_sizes():
    table = KeyTable(n_values=0, capacity=3)
    assert len(table.entries) == 4 and len(table.index) == 2 * 4 + 1
    table.reserve(4)
    assert len(table.entries) == 4
    table.reserve(9)
    assert len(table.entries) == 16 and free_entries(table.index, table.entries) == 16
    with pytest.raises(ValueError, match="n_values"):
        KeyTable(n_values=-1)
