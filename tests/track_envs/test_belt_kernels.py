"""The compiled belt kernels against plain numpy statements of the same formulas."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs.belt_kernels import (
    NOT_PARTICLE,
    PARKED,
    belt_friction,
    land,
    park_exits,
    take_parked,
    window_rows,
    window_state,
)


def _random_rows(rng: np.random.Generator, m: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows = rng.normal(size=(m, 6)) * [0.1, 0.05, 1.0, 0.5, 0.1, 20.0]
    truth = rng.permutation(m).astype(np.int64)
    truth[rng.random(m) < 0.2] = PARKED
    truth[0] = NOT_PARTICLE
    kind = rng.integers(0, 3, size=m)
    return rows, truth, kind


def test_belt_friction_equals_the_coulomb_formula() -> None:
    rng = np.random.default_rng(0)
    rows, truth, kind = _random_rows(rng)
    decel = np.array([1.5, 2.0, 3.0])
    spin_decel = np.array([300.0, 400.0, 500.0])
    h = 0.01
    expected = rows.copy()
    on = truth >= 0
    u = rows[:, 3:5]
    speed = np.linalg.norm(u, axis=1)
    keep = np.maximum(0.0, 1.0 - decel[kind] * h / np.maximum(speed, 1e-12))
    expected[on, 3:5] = u[on] * keep[on, None]
    spin = rows[:, 5]
    expected[on, 5] = (np.sign(spin) * np.maximum(0.0, np.abs(spin) - spin_decel[kind] * h))[on]
    belt_friction(rows, truth, kind, decel, spin_decel, h)
    np.testing.assert_allclose(rows, expected, rtol=0, atol=1e-15)


def test_friction_stops_slip_exactly_and_never_reverses_it() -> None:
    rows = np.zeros((2, 6))
    rows[:, 3] = [-0.004, -0.5]  # slip against the belt: small and large
    truth = np.array([0, 1])
    belt_friction(rows, truth, np.zeros(2, np.int64), np.array([1.57]), np.array([300.0]), 0.01)
    assert rows[0, 3] == 0.0  # 0.004 m/s < a h = 0.0157 m/s: the particle sticks to the belt
    assert rows[1, 3] == pytest.approx(-0.5 + 0.0157)


def test_exits_park_only_particles_past_the_line() -> None:
    rng = np.random.default_rng(1)
    rows, truth, _ = _random_rows(rng)
    before = truth.copy()
    past = (before >= 0) & (rows[:, 0] > 0.05)
    assert park_exits(rows, truth, 0.05) == past.sum()
    assert (truth[past] == PARKED).all()
    np.testing.assert_array_equal(truth[~past], before[~past])
    assert (rows[past, 0] >= 1000.0).all() and (rows[past, 3:] == 0).all()


def test_take_parked_gives_distinct_rows_of_the_right_kind_or_minus_one() -> None:
    truth = np.array([PARKED, 3, PARKED, PARKED, NOT_PARTICLE, PARKED])
    kind = np.array([0, 0, 1, 0, 0, 1])
    got = take_parked(truth, kind, np.array([0, 1, 0, 1, 1, 0]))
    assert got.tolist() == [0, 2, 3, 5, -1, -1]


def test_window_state_selects_sorts_and_moves_to_the_ground_frame() -> None:
    rng = np.random.default_rng(2)
    rows, truth, kind = _random_rows(rng)
    travel, speed = 3.25, 1.44
    ids, position, velocity, angle, kinds = window_state(rows, truth, kind, 3.2, 3.3, travel, speed)
    x = rows[:, 0] + travel
    picked = np.flatnonzero((truth >= 0) & (x >= 3.2) & (x <= 3.3))
    picked = picked[np.argsort(truth[picked])]
    assert len(picked) > 10
    np.testing.assert_array_equal(ids, truth[picked])
    np.testing.assert_array_equal(kinds, kind[picked])
    np.testing.assert_allclose(position, np.column_stack([x[picked], rows[picked, 1]]))
    np.testing.assert_allclose(velocity, np.column_stack([rows[picked, 3] + speed, rows[picked, 4]]))
    np.testing.assert_allclose(angle, rows[picked, 2])


def test_walls_travel_with_the_ground_frame_and_stay_in_place() -> None:
    env = gym.make("BeltSorter-v0")
    env.reset(seed=0)
    world = env.unwrapped.world
    report = empty_report(256, (2,))
    for _ in range(300):
        env.step(report)
    walls = next(b for b in world.space.bodies if b.body_type == b.KINEMATIC)
    # wall body at -s(t) in the belt frame, i.e. fixed to the ground
    assert walls.position.x == pytest.approx(-world.travel, abs=1e-9)
    assert world.travel == pytest.approx(world.params.belt_speed * world.time, rel=1e-9)
    assert walls.velocity.x == -world.params.belt_speed


def test_landing_is_all_or_nothing_and_lands_in_the_belt_frame() -> None:
    truth = np.array([PARKED, 3, PARKED, PARKED, NOT_PARTICLE])
    row_kind = np.array([0, 0, 1, 0, 0])
    rows = np.zeros((5, 6))
    landing = np.array([[0.85, 0.06, 0.07, 0.3], [0.99, 0.06, 0.065, 0.0]])
    half = np.array([0.005, 0.0025])
    geometry = np.array([-0.08, 0.04, 0.18, 2.0, 1.44])  # drop_x, spread, width, travel, belt speed
    uniform = np.array([[0.5, 0.25], [1.0, 0.0], [0.0, 1.0]])
    normal = np.array([[1.0, -1.0, 0.5], [0.0, 0.0, 0.0], [-2.0, 2.0, 1.0]])
    # three kind-1 particles but only one kind-1 body parked: nothing changes
    before = rows.copy(), truth.copy()
    assert not land(rows, truth, row_kind, np.array([1, 1, 1]), uniform, normal, landing, half, geometry, 10)
    np.testing.assert_array_equal(rows, before[0])
    np.testing.assert_array_equal(truth, before[1])
    assert land(rows, truth, row_kind, np.array([0, 1, 0]), uniform, normal, landing, half, geometry, 10)
    assert truth.tolist() == [10, 3, 11, 12, NOT_PARTICLE]
    # ground frame x = -0.08 - 0.04 u0, stored minus the travel; v_x stored minus the belt speed
    np.testing.assert_allclose(rows[0], [-0.10 - 2.0, 0.005 + 0.17 * 0.25, 0.3 * 0.5, 0.91 - 1.44, -0.07, 0])
    np.testing.assert_allclose(rows[2, [0, 1, 3]], [-0.12 - 2.0, 0.0025, 0.99 - 1.44])
    np.testing.assert_allclose(rows[3, [0, 1, 2]], [-0.08 - 2.0, 0.175, 0.3])


@pytest.mark.parametrize("ids", [[7, 5, 6, 9], [10**9, 5, 3 * 10**6, 7]])
def test_window_rows_order_by_id_for_dense_and_sparse_ids(ids: list[int]) -> None:
    truth = np.array([*ids, PARKED, NOT_PARTICLE])
    rows = np.zeros((len(truth), 6))
    rows[1, 0] = 5.0  # out of the window
    got = window_rows(rows, truth, -1.0, 1.0)
    inside = [r for r in range(len(ids)) if r != 1]
    assert got.tolist() == sorted(inside, key=lambda r: ids[r])


def _take_parked_reference(truth: np.ndarray, row_kind: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """The earlier scan: for each new particle in turn, the first free parked row of its kind."""
    out = np.full(len(kinds), -1, dtype=np.int64)
    taken = np.zeros(len(truth), dtype=bool)
    for i, k in enumerate(kinds):
        for r in range(len(truth)):
            if truth[r] == PARKED and row_kind[r] == k and not taken[r]:
                taken[r] = True
                out[i] = r
                break
    return out


@pytest.mark.parametrize("seed", range(20))
def test_take_parked_in_one_pass_equals_the_scan_per_particle(seed: int) -> None:
    rng = np.random.default_rng(seed)
    m = int(rng.integers(0, 60))
    truth = np.where(rng.random(m) < 0.4, PARKED, rng.integers(-2, 50, m)).astype(np.int64)
    row_kind = rng.integers(0, 3, m).astype(np.int64)
    kinds = rng.integers(0, 3, int(rng.integers(0, 25))).astype(np.int64)
    np.testing.assert_array_equal(
        take_parked(truth, row_kind, kinds), _take_parked_reference(truth, row_kind, kinds)
    )


def _touching_reference(x, angles, kinds, table, tol):
    """Connected components of the touching relation over every pair (labels: lowest member)."""
    from track_envs.envs.blobs import core_distance

    n = len(x)
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            i = parent[i]
        return i

    d = np.hypot(x[:, None, 0] - x[None, :, 0], x[:, None, 1] - x[None, :, 1])
    near = np.argwhere(np.triu(d <= 0.03, 1))  # beyond 3 cm no silhouettes of these kinds touch
    for i, j in near:
        a, b = table[kinds[i]], table[kinds[j]]
        gap = core_distance(x[i, 0], x[i, 1], angles[i], a[0], a[1], x[j, 0], x[j, 1], angles[j], b[0], b[1])
        if gap <= a[2] + b[2] + tol:
            ri, rj = find(i), find(j)
            parent[max(ri, rj)] = min(ri, rj)
    return np.array([find(i) for i in range(n)])


@pytest.mark.parametrize(("width", "length"), [(2.0, 0.1), (0.05, 1.0), (0.4, 0.4)])
def test_touching_groups_on_wide_and_long_belts_equal_every_pair(width: float, length: float) -> None:
    from track_envs.envs.belt_physics import BOX_ROUNDING, PARTICLE_KINDS
    from track_envs.envs.blobs import MERGE_TOLERANCE, silhouette_table, touching_groups

    names = ["sphere", "cylinder", "cuboid"]
    table = silhouette_table(
        [(PARTICLE_KINDS[k].shape, PARTICLE_KINDS[k].length, PARTICLE_KINDS[k].width) for k in names],
        BOX_ROUNDING,
    )
    rng = np.random.default_rng(3)
    n = 1500
    x = np.column_stack([rng.uniform(0, length, n), rng.uniform(0, width, n)])  # ≈10 % covered
    kinds = rng.integers(0, 3, n)
    angles = rng.uniform(-np.pi, np.pi, n)
    label = touching_groups(x, angles, kinds, table, MERGE_TOLERANCE)
    expected = _touching_reference(x, angles, kinds, table, MERGE_TOLERANCE)
    assert (expected != np.arange(n)).sum() > 50  # many merges
    np.testing.assert_array_equal(label, expected)


def test_merged_rows_by_table_and_by_search_agree() -> None:
    from track_envs.envs.blobs import MAX_MERGED, merged_rows

    rng = np.random.default_rng(4)
    for spread in (1, 10**9):  # ids nearly consecutive (a table by id), or far apart (a search)
        ids = np.unique(rng.integers(0, 500 * spread, 400))
        rng.shuffle(ids)
        merged = np.full((30, MAX_MERGED), -1, np.int64)
        merged[:, :3] = ids[:90].reshape(30, 3)
        rows = np.concatenate([ids[::3], np.full(50, -1)])
        rng.shuffle(rows)
        got = merged_rows(rows, merged, MAX_MERGED)
        expected = np.full((len(rows), MAX_MERGED), -1, np.int64)
        expected[:, 0] = rows
        for g in range(30):
            expected[rows == merged[g, 0], 1:] = merged[g, 1:]
        np.testing.assert_array_equal(got, expected)
