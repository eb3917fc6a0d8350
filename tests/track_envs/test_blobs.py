"""Merged blobs: touching silhouettes, transitive groups, area-weighted centroids, the env option."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs.belt_physics import BOX_ROUNDING, PARTICLE_KINDS
from track_envs.envs.blobs import (
    MAX_MERGED,
    MERGE_TOLERANCE,
    core_distance,
    merge_blobs,
    merged_rows,
    silhouette_table,
)

KINDS = ["sphere", "cylinder", "cuboid"]
TABLE = silhouette_table(
    [(PARTICLE_KINDS[k].shape, PARTICLE_KINDS[k].length, PARTICLE_KINDS[k].width) for k in KINDS],
    BOX_ROUNDING,
)
SPHERE, CYLINDER, CUBOID = range(3)
R = 0.0025  # sphere radius


def blobs(positions, kinds, angles=None, ids=None, tol=MERGE_TOLERANCE):
    x = np.asarray(positions, dtype=np.float64)
    n = len(x)
    return merge_blobs(
        x,
        np.arange(n, dtype=np.int64) if ids is None else np.asarray(ids, dtype=np.int64),
        np.zeros(n) if angles is None else np.asarray(angles, dtype=np.float64),
        np.asarray(kinds, dtype=np.int64),
        TABLE,
        tol,
        MAX_MERGED,
    )


def test_silhouette_areas_are_closed_form():
    a, b, rho = 0.005, 0.0025, BOX_ROUNDING
    assert TABLE[SPHERE, 3] == pytest.approx(math.pi * R**2)
    assert TABLE[CYLINDER, 3] == pytest.approx(4 * a * b + 4 * rho * (a + b) + math.pi * rho**2)


def test_two_touching_spheres_give_one_detection_at_their_midpoint():
    x = [[0.10, 0.05], [0.10 + 2 * R, 0.05]]
    centres, primary, merged, truncated = blobs(x, [SPHERE, SPHERE], ids=[7, 9])
    np.testing.assert_allclose(centres, [[0.10 + R, 0.05]], rtol=0, atol=1e-15)
    assert primary.tolist() == [7]  # equal areas: the lower id
    assert merged.tolist() == [[7, 9] + [-1] * (MAX_MERGED - 2)]
    assert truncated == 0


def test_separated_spheres_give_two_detections_at_their_centres_exactly():
    x = np.array([[0.10, 0.05], [0.10 + 2 * R + 2 * MERGE_TOLERANCE, 0.05]])
    centres, primary, merged, _ = blobs(x, [SPHERE, SPHERE], ids=[7, 9])
    np.testing.assert_array_equal(centres, x)
    assert primary.tolist() == [7, 9] and merged.shape == (0, MAX_MERGED)


def test_a_sphere_touching_a_cuboid_merges_at_the_area_weighted_centroid():
    cuboid_half = 0.5 * PARTICLE_KINDS["cuboid"].length
    # the sphere touches the cuboid's rounded end face along the cuboid's axis
    x = np.array([[0.2, 0.1], [0.2 + cuboid_half + BOX_ROUNDING + R, 0.1]])
    centres, primary, merged, _ = blobs(x, [CUBOID, SPHERE], ids=[3, 4])
    a_cub, a_sph = TABLE[CUBOID, 3], TABLE[SPHERE, 3]
    expected = (a_cub * x[0] + a_sph * x[1]) / (a_cub + a_sph)
    np.testing.assert_allclose(centres[0], expected, rtol=0, atol=1e-15)
    assert primary.tolist() == [3] and merged[0, :2].tolist() == [3, 4]  # the cuboid is larger


def test_rotation_decides_whether_boxes_touch():
    half_l, half_w = 0.005, 0.0025
    gap = 2 * half_w + 2 * BOX_ROUNDING  # side by side across their axis: touching
    x = [[0.1, 0.05], [0.1, 0.05 + gap]]
    assert len(blobs(x, [CYLINDER, CYLINDER])[0]) == 1
    # turned by 90°, the same centres are closer than their lengths: still touching (overlap)
    assert len(blobs(x, [CYLINDER, CYLINDER], angles=[np.pi / 2, np.pi / 2])[0]) == 1
    # end to end along the axis at the same centre distance + a little: apart
    x = [[0.1, 0.05], [0.1 + 2 * half_l + 2 * BOX_ROUNDING + 2 * MERGE_TOLERANCE, 0.05]]
    assert len(blobs(x, [CYLINDER, CYLINDER])[0]) == 2
    assert len(blobs(x, [CYLINDER, CYLINDER], angles=[np.pi / 2, np.pi / 2])[0]) == 2


def test_groups_are_transitive():
    # a chain of three spheres (first and last far apart) and one apart
    x = [[0.1, 0.05], [0.1 + 2 * R, 0.05], [0.1 + 4 * R, 0.05], [0.2, 0.05]]
    centres, primary, merged, _ = blobs(x, [SPHERE] * 4, ids=[10, 11, 12, 13])
    assert len(centres) == 2 and primary.tolist() == [10, 13]
    np.testing.assert_allclose(centres[0], [0.1 + 2 * R, 0.05], atol=1e-15)
    assert sorted(merged[0][merged[0] >= 0].tolist()) == [10, 11, 12]


def test_more_members_than_columns_keeps_the_largest_and_counts_the_rest():
    n = MAX_MERGED + 3
    x = [[0.1 + 2 * R * i, 0.05] for i in range(n)]
    kinds = [SPHERE] * n
    kinds[-1] = CUBOID
    _, primary, merged, truncated = blobs(x, kinds)
    assert truncated == 3 and primary.tolist() == [n - 1]
    assert merged[0, 0] == n - 1 and np.all(merged[0] >= 0)


def test_merged_rows_lists_members_on_the_primary_row_only():
    detection_ids = np.array([5, 2, -1, 8, -1], dtype=np.int64)
    merged = np.full((1, MAX_MERGED), -1, dtype=np.int64)
    merged[0, :3] = [8, 3, 4]
    out = merged_rows(detection_ids, merged, MAX_MERGED)
    np.testing.assert_array_equal(out[:, 0], detection_ids)
    assert out[3, :3].tolist() == [8, 3, 4]
    assert np.all(out[[0, 1, 2, 4], 1:] == -1)


def _boundary(x, y, t, a, b, step):
    """Points every ``step`` along the rectangle's edges (a point for a degenerate core)."""
    c, s = math.cos(t), math.sin(t)
    corners = [(a, b), (-a, b), (-a, -b), (a, -b)]
    pts = []
    for k in range(4):
        (u0, v0), (u1, v1) = corners[k], corners[(k + 1) % 4]
        m = max(int(math.hypot(u1 - u0, v1 - v0) / step), 1)
        for f in np.linspace(0, 1, m + 1):
            u, v = u0 + f * (u1 - u0), v0 + f * (v1 - v0)
            pts.append((x + c * u - s * v, y + s * u + c * v))
    return np.array(pts)


def _inside(p, x, y, t, a, b):
    c, s = math.cos(t), math.sin(t)
    u = c * (p[:, 0] - x) + s * (p[:, 1] - y)
    v = -s * (p[:, 0] - x) + c * (p[:, 1] - y)
    return (np.abs(u) <= a) & (np.abs(v) <= b)


@settings(max_examples=150, deadline=None)
@given(
    st.floats(-0.02, 0.02),
    st.floats(-0.02, 0.02),
    st.floats(-3.2, 3.2),
    st.floats(-3.2, 3.2),
    st.sampled_from([(0.0, 0.0), (0.005, 0.0025), (0.004, 0.003)]),
    st.sampled_from([(0.0, 0.0), (0.005, 0.0025), (0.004, 0.003)]),
)
def test_core_distance_matches_dense_boundary_sampling(dx, dy, ti, tj, ci, cj):
    step = 2e-5
    p = _boundary(0.0, 0.0, ti, *ci, step)
    q = _boundary(dx, dy, tj, *cj, step)
    overlap = _inside(q, 0.0, 0.0, ti, *ci).any() or _inside(p, dx, dy, tj, *cj).any()
    sampled = 0.0 if overlap else float(np.min(np.hypot(*(p[:, None, :] - q[None, :, :]).transpose(2, 0, 1))))
    d = core_distance(0.0, 0.0, ti, *ci, dx, dy, tj, *cj)
    assert d <= sampled + 1e-12
    assert d >= sampled - 2 * step


# -- the env option ---------------------------------------------------------------------------
DIGESTS = Path(__file__).parent / "data" / "belt_sorter_seed0_200.json"


def episode_digests(env, seed: int, steps: int) -> list[str]:
    """Per-frame digest of the observation and the truth (the layout of the recorded file)."""
    obs, info = env.reset(seed=seed)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    out = []
    for t in range(steps + 1):
        h = hashlib.sha256()
        for a in (
            obs["detections"],
            obs["mask"],
            info["detection_ids"],
            info["truth"]["ids"],
            info["truth"]["positions"],
            info["truth"]["velocities"],
        ):
            h.update(np.ascontiguousarray(a).tobytes())
        out.append(h.hexdigest()[:16])
        if t < steps:
            obs, _, _, _, info = env.step(report)
    return out


def test_merging_off_reproduces_the_first_release_bit_for_bit():
    # digests recorded with BeltSorter-v0 before blobs existed (seed 0, 200 steps, empty reports);
    # without the nozzle bar, whose particles stay on the belt longer
    recorded = json.loads(DIGESTS.read_text())
    env = gym.make("BeltSorter-v0", merge_touching=False, nozzle_offset=None)
    got = episode_digests(env, recorded["seed"], recorded["steps"])
    first_bad = next(
        (t for t, (a, b) in enumerate(zip(got, recorded["digests"], strict=True)) if a != b), None
    )
    assert first_bad is None, f"frame {first_bad} differs from the recorded stream"


def test_merged_stream_is_consistent_with_truth_and_areas():
    env = gym.make("BeltSorter-v0", noise_std=0.0)
    u = env.unwrapped
    assert u.merge_touching  # the default
    obs, info = env.reset(seed=3)
    report = empty_report(u.sensor_spec.max_tracks, (2,))
    merged_seen = 0
    for _ in range(30):
        truth = info["truth"]
        at = {int(i): k for k, i in enumerate(truth["ids"]) if i >= 0}
        rows = np.flatnonzero(obs["mask"])
        members = info["detection_ids_merged"][rows]
        np.testing.assert_array_equal(members[:, 0], info["detection_ids"][rows])
        listed = members[members >= 0]
        # every particle in the window is behind exactly one detection
        assert sorted(listed.tolist()) == sorted(at)
        for row, ids in zip(rows, members, strict=True):
            ids = ids[ids >= 0]
            k = [at[int(i)] for i in ids]
            area = u._silhouettes[truth["kinds"][k], 3]
            expected = (area[:, None] * truth["positions"][k]).sum(0) / area.sum()
            np.testing.assert_allclose(obs["detections"][row], expected, atol=2e-7)
            assert area[0] == area.max()  # the listed primary has the largest area
            merged_seen += len(ids) > 1
        obs, _, _, _, info = env.step(report)
    assert merged_seen > 30  # the default belt merges a few particles per frame


def test_bad_merge_arguments_are_named():
    with pytest.raises(ValueError, match="merge_touching"):
        gym.make("BeltSorter-v0", merge_touching="yes")
    with pytest.raises(ValueError, match="merge_tolerance"):
        gym.make("BeltSorter-v0", merge_tolerance=-1.0)


@pytest.mark.parametrize("seed", range(5))
def test_grouping_equals_brute_force_over_every_pair(seed):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from track_envs.envs.blobs import touching_groups

    rng = np.random.default_rng(seed)
    n = 200
    x = np.column_stack([rng.uniform(0, 0.2, n), rng.uniform(0, 0.05, n)])  # dense: many contacts
    kinds = rng.integers(0, 3, n)
    angles = rng.uniform(-np.pi, np.pi, n)
    label = touching_groups(x, angles, kinds, TABLE, MERGE_TOLERANCE)
    rows, cols = [], []
    for i in range(n):
        for j in range(i + 1, n):
            a, b = TABLE[kinds[i]], TABLE[kinds[j]]
            gap = core_distance(
                x[i, 0], x[i, 1], angles[i], a[0], a[1], x[j, 0], x[j, 1], angles[j], b[0], b[1]
            )
            if gap <= a[2] + b[2] + MERGE_TOLERANCE:
                rows.append(i)
                cols.append(j)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, expected = connected_components(graph, directed=False)
    assert len(rows) > 20
    # the same partition: equal labels exactly where the brute-force components are equal
    np.testing.assert_array_equal(label[:, None] == label[None, :], expected[:, None] == expected[None, :])
    first = np.array([np.flatnonzero(expected == expected[i])[0] for i in range(n)])
    np.testing.assert_array_equal(label, first)
