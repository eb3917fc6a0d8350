"""The nozzle bar's crossing truth (BeltSorter-v0, BeltReplay-v0) and the nozzle_offset argument."""

from __future__ import annotations

import copy
import pickle
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs import belt_physics
from track_envs.envs.belt_physics import PARTICLE_KINDS, BeltParams, BeltWorld
from track_envs.envs.nozzle import recorded_crossings
from track_envs.io.wide_tracks import write_track_csv


@pytest.fixture
def puck(monkeypatch):
    """A particle kind without belt friction, so that a lone particle moves on a straight line."""
    kind = replace(PARTICLE_KINDS["sphere"], name="puck", belt_friction=0.0, lateral_speed_std=0.01)
    monkeypatch.setitem(belt_physics.PARTICLE_KINDS, "puck", kind)
    return "puck"


@pytest.mark.parametrize("substeps", [1, 3])
def test_crossing_of_a_straight_line_particle_matches_the_closed_form(puck, substeps):
    params = BeltParams(feed_rate=0.0, warmup_time=0.0, substeps=substeps)
    line = params.window_length + 0.05
    dt = 0.01
    world = BeltWorld(params, {puck: 1.0}, np.random.default_rng(3), dt, line_x=line)
    world._drop(1)
    world._write(poses=True)
    start = world.state()
    (x0, y0), (vx, vy) = start.position[0], start.velocity[0]
    assert vx > 0.5 and vy != 0.0
    found = []
    for frame in range(200):
        world.step()
        ids, fraction, lateral = world.crossings
        found += [(frame + f) * dt for f in fraction]
        if len(ids):
            assert ids.tolist() == start.ids.tolist()
            y_crossing = lateral[0]
    t_closed = (line - x0) / vx  # x(t) = x0 + vx t on the belt, in the ground frame
    assert len(found) == 1
    assert found[0] == pytest.approx(t_closed, abs=1e-12)
    assert y_crossing == pytest.approx(y0 + vy * t_closed, abs=1e-12)


def test_line_crossings_interpolates_within_the_step():
    from track_envs.envs.belt_kernels import line_crossings

    before = np.array([[0.40, 0.01, 0, 0, 0, 0], [0.30, 0.02, 0, 0, 0, 0], [0.40, 0.0, 0, 0, 0, 0]])
    after = np.array([[0.46, 0.04, 0, 0, 0, 0], [0.31, 0.02, 0, 0, 0, 0], [0.50, 0.0, 0, 0, 0, 0]])
    truth = np.array([7, 8, -1])  # the third row is parked: never a crossing
    # line at ground x = 0.45, belt travelled 0 → 0.0 during the step
    ids, fraction, lateral = line_crossings(before, after, truth, 0.45, 0.45)
    assert ids.tolist() == [7]
    assert fraction[0] == pytest.approx(0.05 / 0.06)
    assert lateral[0] == pytest.approx(0.01 + 0.03 * 0.05 / 0.06)


def test_belt_sorter_reports_each_crossing_once_within_its_frame():
    env = gym.make("BeltSorter-v0", noise_std=0.0)
    u = env.unwrapped
    assert u.sensor_spec.sorting_line == pytest.approx(u.physics.window_length + 0.05)
    _, info = env.reset(seed=1)
    report = empty_report(u.sensor_spec.max_tracks, (2,))
    seen: set[int] = set()
    crossed: list[int] = []
    for _ in range(120):
        _, _, _, _, info = env.step(report)
        truth = info["truth"]
        assert truth["nozzle_ids"].shape == truth["nozzle_times"].shape == (u.max_targets,)
        live = truth["nozzle_ids"] >= 0
        times = truth["nozzle_times"][live]
        assert np.all((times > info["t"] - u.sensor_spec.dt - 1e-12) & (times <= info["t"] + 1e-12))
        lateral = truth["nozzle_lateral"][live]
        assert np.all((lateral > 0) & (lateral < u.physics.window_width))
        crossed += truth["nozzle_ids"][live].tolist()
        seen |= set(truth["ids"][truth["ids"] >= 0].tolist())
    assert len(crossed) > 150  # ≈2 particles per frame
    assert len(set(crossed)) == len(crossed)
    assert len(set(crossed) - seen) <= 10  # all but those past the window when the episode began


def test_without_a_nozzle_bar_there_are_no_crossings():
    env = gym.make("BeltSorter-v0", nozzle_offset=None)
    assert env.unwrapped.sensor_spec.sorting_line is None
    env.reset(seed=0)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    for _ in range(30):
        _, _, _, _, info = env.step(report)
        assert np.all(info["truth"]["nozzle_ids"] == -1)


def test_copies_continue_the_crossings():
    env = gym.make("BeltSorter-v0")
    env.reset(seed=2)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    for _ in range(40):
        env.step(report)
    twins = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    for _ in range(20):
        _, _, _, _, info = env.step(report)
        for twin in twins:
            _, _, _, _, other = twin.step(report)
            for key in ("nozzle_ids", "nozzle_times", "nozzle_lateral"):
                np.testing.assert_array_equal(other["truth"][key], info["truth"][key])


@pytest.mark.parametrize("bad", [0.0, -0.01, 0.3, float("nan"), "0.05", True])
def test_bad_nozzle_offset_is_named(bad):
    with pytest.raises(ValueError, match="nozzle_offset"):
        gym.make("BeltSorter-v0", nozzle_offset=bad)


# -- BeltReplay-v0 ------------------------------------------------------------------------------
def _straight_recording(tmp_path, frames=60, dt=0.01):
    """Two particles on straight lines: x = x0 + v t, y = y0 + w t (NaN before they appear)."""
    t = np.arange(frames) * dt
    tracks = np.full((frames, 2, 2), np.nan)
    tracks[:, 0, 0], tracks[:, 0, 1] = 0.01 + 1.3 * t, 0.05 + 0.02 * t
    tracks[5:, 1, 0], tracks[5:, 1, 1] = 0.0 + 1.1 * (t[5:] - t[5]), 0.12 - 0.01 * (t[5:] - t[5])
    path = tmp_path / "straight.csv"
    write_track_csv(path, tracks)
    return path, tracks


def test_replay_crossings_match_the_closed_form(tmp_path):
    path, _ = _straight_recording(tmp_path)
    env = gym.make("BeltReplay-v0", path=path, region=((0.0, 0.0), (0.3, 0.18)), nozzle_offset=0.1)
    line = env.unwrapped.sensor_spec.sorting_line
    assert line == pytest.approx(0.4)
    env.reset(seed=0)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    got = {}
    while True:
        _, _, terminated, truncated, info = env.step(report)
        live = info["truth"]["nozzle_ids"] >= 0
        for i, t, y in zip(
            *(info["truth"][k][live] for k in ("nozzle_ids", "nozzle_times", "nozzle_lateral")), strict=True
        ):
            got[int(i)] = (t, y)
        if terminated or truncated:
            break
    t0 = (line - 0.01) / 1.3
    t1 = 0.05 + (line - 0.0) / 1.1
    assert got[0] == pytest.approx((t0, 0.05 + 0.02 * t0), abs=1e-9)
    assert got[1] == pytest.approx((t1, 0.12 - 0.01 * (t1 - 0.05)), abs=1e-9)


def test_replay_that_does_not_reach_the_bar_says_so(tmp_path):
    path, _ = _straight_recording(tmp_path, frames=20)  # ends at x ≈ 0.26
    with pytest.raises(ValueError, match="cannot give the nozzle crossings"):
        gym.make("BeltReplay-v0", path=path, region=((0.0, 0.0), (0.2, 0.18)), nozzle_offset=0.1)
    with pytest.raises(ValueError, match="cannot give the nozzle crossings"):
        gym.make("BeltReplay-v0", nozzle_offset=0.01)  # the shipped sample ends at the window


def test_recorded_crossings_skip_gaps():
    tracks = np.array([[[0.1, 0.0]], [[np.nan, np.nan]], [[0.5, 0.0]]])
    _, ids, _, _ = recorded_crossings(tracks, 0.3, 0.01)
    assert len(ids) == 0
