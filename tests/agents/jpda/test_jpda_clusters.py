"""Gating clusters against a breadth-first search over the gate graph."""

from __future__ import annotations

import numpy as np
import pytest

from agents.jpda.clusters import gate_clusters


def bfs_components(gate: np.ndarray) -> set[tuple[frozenset[int], frozenset[int]]]:
    n, m = gate.shape
    seen_t, seen_d = set(), set()
    out = set()
    for start in [("t", i) for i in range(n)] + [("d", j) for j in range(m)]:
        if (start[0] == "t" and start[1] in seen_t) or (start[0] == "d" and start[1] in seen_d):
            continue
        tracks, dets, todo = set(), set(), [start]
        while todo:
            kind, k = todo.pop()
            if kind == "t" and k not in tracks:
                tracks.add(k)
                todo += [("d", j) for j in np.flatnonzero(gate[k]).tolist()]
            elif kind == "d" and k not in dets:
                dets.add(k)
                todo += [("t", i) for i in np.flatnonzero(gate[:, k]).tolist()]
        seen_t |= tracks
        seen_d |= dets
        out.add((frozenset(tracks), frozenset(dets)))
    return out


def test_components_match_breadth_first_search() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        n, m = int(rng.integers(0, 9)), int(rng.integers(0, 9))
        gate = rng.random((n, m)) < rng.uniform(0.0, 0.4)
        cl = gate_clusters(gate)
        got = {(frozenset(t.tolist()), frozenset(d.tolist())) for t, d in cl.members()}
        assert got == bfs_components(gate)
        assert cl.n_clusters == len(got)
        np.testing.assert_array_equal(cl.n_tracks(), [len(t) for t, _ in cl.members()])
        np.testing.assert_array_equal(cl.n_detections(), [len(d) for _, d in cl.members()])
        # Every gated pair lies inside one cluster.
        rows, cols = np.nonzero(gate)
        np.testing.assert_array_equal(cl.track_cluster[rows], cl.detection_cluster[cols])


def test_chain_is_one_cluster_and_lone_vertices_are_their_own() -> None:
    gate = np.array(
        [
            [1, 1, 0, 0, 0],
            [0, 1, 1, 0, 0],
            [0, 0, 1, 0, 0],
            [0, 0, 0, 0, 0],
        ],
        dtype=bool,
    )
    cl = gate_clusters(gate)
    assert cl.n_clusters == 4  # chain t0-t2 with d0-d2, lone t3, lone d3, lone d4
    assert len(set(cl.track_cluster[:3].tolist())) == 1
    assert cl.track_cluster[3] not in cl.detection_cluster
    assert len(set(cl.detection_cluster[3:].tolist()) | {cl.track_cluster[0]}) == 3


def test_bad_gate_is_named() -> None:
    with pytest.raises(
        ValueError, match=r"gate must be a \(n_tracks, n_detections\) matrix, got shape \(3,\)"
    ):
        gate_clusters(np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match="gate must be boolean, got dtype float64"):
        gate_clusters(np.ones((2, 2)))
