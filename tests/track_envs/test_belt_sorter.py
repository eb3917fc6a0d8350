"""BeltSorter-v0: calibration against the DEM figures, walls, sensor model, arguments."""

from __future__ import annotations

import copy
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs.belt_physics import BeltParams, BeltWorld, resolve_mixture
from track_envs.envs.belt_statistics import DEM_FIGURES, belt_statistics
from track_envs.testing import assert_equal_trees as assert_tree_equal

# DEM figures per data set (the three belts of Pollithy et al. 2020): entry speed, exit speed.
KIND_FIGURES = {
    "sphere": {"entry_speed": 1.12, "exit_speed": 1.44, "frames_seen": 31.0},
    "cylinder": {"entry_speed": 1.00, "exit_speed": 1.43, "frames_seen": 33.0},
    "cuboid": {"entry_speed": 1.00, "exit_speed": 1.43, "frames_seen": 33.0},
}


def within(value: float, low: float, high: float, tol: float = 0.15) -> bool:
    return low * (1 - tol) <= value <= high * (1 + tol)


@pytest.fixture(scope="module")
def default_stats():
    return belt_statistics(gym.make("BeltSorter-v0"), n_frames=1500, seed=0)


@pytest.mark.parametrize("name", list(DEM_FIGURES))
def test_default_flow_matches_the_dem_figures_within_15_percent(default_stats, name):
    low, high = DEM_FIGURES[name]
    assert within(default_stats[name], low, high), (name, default_stats[name], (low, high))


@pytest.mark.parametrize("kind", list(KIND_FIGURES))
def test_each_particle_kind_matches_its_own_data_set(kind):
    stats = belt_statistics(gym.make("BeltSorter-v0", particle_kind=kind), n_frames=600, seed=1)
    for name, figure in KIND_FIGURES[kind].items():
        assert within(stats[name], figure, figure), (kind, name, stats[name], figure)
    assert within(stats["acceleration"], 1.57, 1.57)
    assert within(stats["lateral_speed_p98"], 0.07, 0.09)


def test_spheres_enter_faster_than_cylinders():
    fast = belt_statistics(gym.make("BeltSorter-v0", particle_kind="sphere"), n_frames=300, seed=0)
    slow = belt_statistics(gym.make("BeltSorter-v0", particle_kind="cylinder"), n_frames=300, seed=0)
    assert fast["entry_speed"] > slow["entry_speed"] + 0.05


def test_no_particle_ever_crosses_a_wall():
    world = BeltWorld(BeltParams(), resolve_mixture("mixture"), np.random.default_rng(5), 0.01)
    world.warm_up()
    width = world.params.window_width
    half_min = min(0.5 * min(k.length, k.width) for k in world.kinds)
    worst = np.inf
    for _ in range(1500):
        world.step()
        y = world.state().position[:, 1]
        worst = min(worst, float(np.min(np.minimum(y, width - y))))
    # centroids stay inside the walls, and overlap with a wall never exceeds half the smallest half-size
    assert worst > 0.5 * half_min


def test_belt_is_in_steady_state_at_the_first_frame():
    env = gym.make("BeltSorter-v0")
    _, info = env.reset(seed=0)
    truth = info["truth"]
    live = truth["ids"] >= 0
    assert live.sum() > 20
    assert truth["positions"][live, 0].max() > 0.35, "particles already reach the window end"
    assert np.all(truth["velocities"][live, 0] > 0.5)


def test_truth_velocities_match_position_differences():
    env = gym.make("BeltSorter-v0")
    _, a = env.reset(seed=0)
    _, _, _, _, b = env.step(empty_report(256, (2,)))
    ids_a, ids_b = a["truth"]["ids"], b["truth"]["ids"]
    common, ia, ib = np.intersect1d(ids_a[ids_a >= 0], ids_b[ids_b >= 0], return_indices=True)
    dx = b["truth"]["positions"][ib] - a["truth"]["positions"][ia]
    v = b["truth"]["velocities"][ib]
    assert len(common) > 20
    np.testing.assert_allclose(dx / 0.01, v, atol=0.05)


def test_measurement_noise_has_the_requested_std():
    env = gym.make("BeltSorter-v0", noise_std=3e-4, merge_touching=False)  # one detection per particle
    obs, info = env.reset(seed=0)
    errors = []
    for _ in range(100):
        truth = dict(zip(info["truth"]["ids"].tolist(), info["truth"]["positions"], strict=True))
        rows = np.flatnonzero(obs["mask"])
        errors.append(obs["detections"][rows] - np.array([truth[i] for i in info["detection_ids"][rows]]))
        obs, _, _, _, info = env.step(empty_report(256, (2,)))
    errors = np.concatenate(errors)
    assert len(errors) > 3000
    np.testing.assert_allclose(errors.std(axis=0), 3e-4, rtol=0.05)
    np.testing.assert_allclose(errors.mean(axis=0), 0.0, atol=3e-5)


def test_detection_probability_and_clutter_rate():
    env = gym.make("BeltSorter-v0", p_detect=0.7, clutter_rate=3.0, merge_touching=False)
    obs, info = env.reset(seed=0)
    detected = visible = clutter = 0
    frames = 200
    for _ in range(frames):
        src = info["detection_ids"][obs["mask"] == 1]
        detected += int((src >= 0).sum())
        clutter += int((src == -1).sum())
        visible += int((info["truth"]["ids"] >= 0).sum())
        obs, _, _, _, info = env.step(empty_report(256, (2,)))
    rate = detected / visible
    sigma = np.sqrt(0.7 * 0.3 / visible)
    assert abs(rate - 0.7) < 4 * sigma
    assert abs(clutter / frames - 3.0) < 4 * np.sqrt(3.0 / frames)


def test_overfull_frames_warn_once_and_count_what_they_drop():
    env = gym.make("BeltSorter-v0", max_detections=20, max_targets=30, overflow="drop")
    with (
        pytest.warns(RuntimeWarning, match="max_detections=20"),
        pytest.warns(RuntimeWarning, match="max_targets=30"),
    ):
        _, info = env.reset(seed=0)
    assert info["dropped_detections"] > 0 and info["dropped_targets"] > 0
    assert (info["truth"]["ids"] >= 0).sum() == 30


def test_overfull_frames_grow_the_rows_and_the_spaces():
    env = gym.make("BeltSorter-v0", max_detections=20, max_targets=30)
    with (
        pytest.warns(RuntimeWarning, match=r"exceed max_detections=20; the observation grows to \d+ rows"),
        pytest.warns(RuntimeWarning, match=r"exceed max_targets=30; the rows of info\['truth'\] grow"),
    ):
        obs, info = env.reset(seed=0)
    base = env.unwrapped
    rows = base.sensor_spec.max_detections
    assert rows in (40, 80, 160, 320) and obs["detections"].shape == (rows, 2)
    assert obs["mask"].sum() == (info["detection_ids"] >= 0).sum() + 0  # no clutter by default
    assert obs["mask"].sum() > 20 and info["dropped_detections"] == 0 and info["dropped_targets"] == 0
    assert env.observation_space.contains(obs)
    assert env.action_space["detection"].shape == (base.sensor_spec.max_tracks,)
    assert base.max_targets >= (info["truth"]["ids"] >= 0).sum() > 30
    # nothing is dropped: the truth lists every particle of the window
    state = base.world.state((0.0, base.physics.window_length))
    np.testing.assert_array_equal(info["truth"]["ids"][: len(state.ids)], state.ids)
    obs, *_ = env.step(empty_report(base.sensor_spec.max_tracks, (2,)))
    assert env.observation_space.contains(obs)


def test_observation_sizes_follow_the_scene():
    from track_envs.envs.belt_physics import expected_in_view, scene_rows

    default = gym.make("BeltSorter-v0").unwrapped
    assert (default.sensor_spec.max_detections, default.sensor_spec.max_tracks, default.max_targets) == (
        256,
        256,
        256,
    )
    assert expected_in_view(BeltParams(), {"cylinder": 1.0}) == pytest.approx(61.8, abs=0.1)  # DEM: 58–73
    busy = gym.make("BeltSorter-v0", feed_rate=1560.0).unwrapped  # ≈500 in view
    rows = scene_rows(busy.physics, busy.kinds)
    assert rows % 256 == 0 and rows >= 3 * expected_in_view(busy.physics, busy.kinds)
    assert (busy.sensor_spec.max_detections, busy.sensor_spec.max_tracks, busy.max_targets) == (rows,) * 3
    given = gym.make("BeltSorter-v0", feed_rate=1560.0, max_detections=64, max_tracks=32).unwrapped
    assert (given.sensor_spec.max_detections, given.sensor_spec.max_tracks, given.max_targets) == (
        64,
        32,
        rows,
    )
    industrial = gym.make("BeltSorter-v0", physics=BeltParams.industrial()).unwrapped
    n = expected_in_view(industrial.physics, industrial.kinds)
    assert 11_500 < n < 12_500
    assert industrial.sensor_spec.max_detections == industrial.max_targets == 17_664 > 1.4 * n


def test_the_industrial_preset():
    p = BeltParams.industrial()
    assert (p.window_width, p.window_length, p.feed_rate, p.feed_burstiness, p.warmup_time) == (
        2.0,
        4.0,
        4300.0,
        0.17,
        3.5,
    )
    assert (p.belt_speed, p.drop_x, p.drop_spread, p.substeps) == (1.44, -0.08, 0.04, 1)  # the defaults'
    assert BeltParams.industrial(feed_rate=100.0).feed_rate == 100.0
    with pytest.raises(TypeError):
        BeltParams.industrial(window_hight=1.0)


def test_a_short_wide_belt_holds_what_its_feed_implies():
    """A 2 m wide belt seen over 0.5 m (the preset's width and feed, a short window): the count in
    view follows the kinematics of expected_in_view, the derived sizes hold every particle."""
    from track_envs.envs.belt_physics import expected_in_view

    physics = BeltParams.industrial(window_length=0.5, warmup_time=0.8)
    env = gym.make("BeltSorter-v0", physics=physics)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow
        _, info = env.reset(seed=0)
        counts = [(info["truth"]["ids"] >= 0).sum()]
        report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
        for _ in range(20):
            _, _, _, _, info = env.step(report)
            counts.append((info["truth"]["ids"] >= 0).sum())
    expected = expected_in_view(physics, {"cylinder": 1.0})
    assert 1_550 < expected < 1_750
    assert 0.75 * expected < np.mean(counts) < 1.25 * expected


@pytest.mark.slow
def test_the_industrial_belt_holds_ten_thousand_particles_in_view():
    env = gym.make("BeltSorter-v0", physics=BeltParams.industrial())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the derived sizes hold every particle and detection
        obs, info = env.reset(seed=0)
        counts = [(info["truth"]["ids"] >= 0).sum()]
        report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
        for _ in range(10):
            obs, _, _, _, info = env.step(report)
            counts.append((info["truth"]["ids"] >= 0).sum())
    assert min(counts) >= 10_000
    assert obs["mask"].sum() > 8_000  # touching particles merge into fewer detections


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"noise_std": -1.0}, "noise_std"),
        ({"merge_tolerance": 0.05}, r"merge_tolerance must be a gap in \[0, 0.01\] m .* got 0.05"),
        ({"overflow": "truncate"}, "overflow must be 'grow' or 'drop', got 'truncate'"),
        ({"p_detect": 1.5}, "p_detect"),
        ({"clutter_rate": -0.1}, "clutter_rate"),
        ({"max_detections": 0}, "max_detections"),
        ({"max_tracks": 2.5}, "max_tracks"),
        ({"particle_kind": "pebble"}, "particle_kind must be one of"),
        ({"particle_kind": {"sphere": 1.0, "rock": 1.0}}, "unknown kinds"),
        ({"feed_rate": -5.0}, "feed_rate"),
        ({"belt_speed": 0.0}, "belt_speed"),
        ({"gospa_c": 0.0}, "gospa_c"),
        ({"physics": {"belt_speed": 1.0}}, "BeltParams"),
    ],
)
def test_bad_arguments_name_the_problem(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make("BeltSorter-v0", **kwargs)


def test_mixture_carries_every_kind():
    env = gym.make("BeltSorter-v0", particle_kind={"sphere": 1, "cuboid": 3})
    _, info = env.reset(seed=0)
    kinds = info["truth"]["kinds"][info["truth"]["ids"] >= 0]
    names = np.array(env.unwrapped.kind_names)[kinds]
    assert set(names) == {"sphere", "cuboid"}
    assert (names == "cuboid").mean() > 0.5


def test_reward_is_zero_for_a_perfect_report_and_negative_otherwise():
    env = gym.make("BeltSorter-v0", noise_std=0.0)
    _, info = env.reset(seed=0)
    live = info["truth"]["ids"] >= 0
    report = empty_report(256, (2,))
    n = int(live.sum())
    report["positions"][:n] = info["truth"]["positions"][live]
    report["ids"][:n] = info["truth"]["ids"][live]
    report["mask"][:n] = 1
    _, reward, *_ = env.step(report)
    assert reward == pytest.approx(0.0, abs=1e-6)
    _, reward, *_ = env.step(empty_report(256, (2,)))
    assert reward < -0.01


# -- copying and pickling (the contract tests check 500 frames of every env id) ---------------------


def belt_frames(env, n: int) -> list[tuple]:
    report = empty_report(256, (2,))
    return [env.step(report) for _ in range(n)]


def test_a_pickle_continues_the_episode_bit_for_bit_in_another_process(tmp_path):
    env = gym.make("BeltSorter-v0", particle_kind="mixture")
    env.reset(seed=7)
    belt_frames(env, 40)
    (tmp_path / "env.pkl").write_bytes(pickle.dumps(env))
    code = (
        "import pickle, sys\n"
        "from track_envs.contracts.report import empty_report\n"
        "env = pickle.loads(open(sys.argv[1], 'rb').read())\n"
        "frames = [env.step(empty_report(256, (2,))) for _ in range(100)]\n"
        "open(sys.argv[2], 'wb').write(pickle.dumps(frames))\n"
    )
    subprocess.run([sys.executable, "-c", code, tmp_path / "env.pkl", tmp_path / "out.pkl"], check=True)
    restored = pickle.loads((tmp_path / "out.pkl").read_bytes())
    assert_tree_equal(restored, belt_frames(env, 100))


def test_copies_are_exact_in_a_later_episode_and_before_the_first_reset():
    env = gym.make("BeltSorter-v0")
    fresh = copy.deepcopy(env)  # before reset: nothing to replay
    fresh.reset(seed=1)
    env.reset(seed=1)
    assert_tree_equal(belt_frames(fresh, 30), belt_frames(env, 30))
    env.reset()  # the second episode starts from the generator's state, not from a seed
    belt_frames(env, 20)
    clone = pickle.loads(pickle.dumps(env))
    assert_tree_equal(belt_frames(clone, 100), belt_frames(env, 100))


@pytest.mark.parametrize("overflow", ["drop", "grow"])
def test_a_copy_of_an_overfull_belt_keeps_its_counts_without_warning_again(overflow):
    env = gym.make("BeltSorter-v0", max_detections=20, max_targets=30, overflow=overflow)
    with pytest.warns(RuntimeWarning):
        env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a grown belt may grow again
        belt_frames(env, 5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        clone = copy.deepcopy(env)
    assert clone.unwrapped.sensor_spec == env.unwrapped.sensor_spec
    assert clone.observation_space == env.observation_space
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = belt_frames(env, 50), belt_frames(clone, 50)
    dropped = b[-1][4]["dropped_detections"] > 0 and b[-1][4]["dropped_targets"] > 0
    assert dropped == (overflow == "drop")
    assert_tree_equal(b, a)


@pytest.mark.parametrize("change", ["draw from np_random", "move a particle"])
def test_a_belt_changed_outside_step_refuses_to_restore(change):
    env = gym.make("BeltSorter-v0")
    env.reset(seed=0)
    belt_frames(env, 10)
    if change == "draw from np_random":
        env.unwrapped.np_random.random()
    else:
        env.unwrapped.world._rows[np.flatnonzero(env.unwrapped.world._row_truth >= 0)[0], 4] += 1e-3
    data = pickle.dumps(env)
    with pytest.raises(RuntimeError, match=r"replaying its episode from the start \(10 frames\) did not"):
        pickle.loads(data)


def test_a_belt_world_alone_refuses_to_pickle_and_names_the_env_instead():
    world = BeltWorld(BeltParams(), resolve_mixture("cylinder"), np.random.default_rng(0), 0.01)
    with pytest.raises(TypeError, match="pickle or deep-copy the BeltSorterEnv instead"):
        pickle.dumps(world)
    with pytest.raises(TypeError, match="BeltSorterEnv"):
        copy.deepcopy(world)


def test_a_preset_name_stands_for_its_belt():
    """``physics="industrial"`` is ``BeltParams.industrial()``; an unknown name is an error naming
    the valid names."""
    env = gym.make("BeltSorter-v0", physics="industrial")
    assert env.unwrapped.physics == BeltParams.industrial()
    assert gym.make("BeltSorter-v0", physics="default").unwrapped.physics == BeltParams()
    with pytest.raises(ValueError, match=r"one of \['default', 'industrial'\].*'wide'"):
        gym.make("BeltSorter-v0", physics="wide")
