"""Drifting sensors: schedules reproducible and bounded, envs keep the nominal spec, truth in info."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs.drift import (
    BLOCK,
    DRIFT_PRESETS,
    DriftProcess,
    RandomWalk,
    SensorDrift,
    SensorValues,
    Steps,
    resolve_drift,
)

NOMINAL = SensorValues(1e-4, 1.0, 0.0)
POINT_ENVS = ("BeltSorter-v0", "BeltReplay-v0", "SineTarget-v0", "PiecewiseTarget-v0")


def _drift_for(env_id: str) -> SensorDrift:
    if env_id.startswith("Belt"):
        return DRIFT_PRESETS["belt"]
    return SensorDrift(
        noise_std=RandomWalk(0.05, 0.5, step=0.05, log=True),
        p_detect=Steps(0.5, 0.9, mean_hold=40),
        clutter_rate=Steps(0.0, 3.0, mean_hold=50),
    )


def _values(drift: SensorDrift, seed: int, n: int) -> np.ndarray:
    return DriftProcess(drift.checked(), NOMINAL, seed).values(n).copy()


def test_same_seed_same_drift_and_other_seeds_differ():
    drift = DRIFT_PRESETS["belt"]
    a, b, c = _values(drift, 7, 1000), _values(drift, 7, 1000), _values(drift, 8, 1000)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_a_frame_value_does_not_depend_on_when_it_is_asked_for():
    process = DriftProcess(DRIFT_PRESETS["belt"].checked(), NOMINAL, 3)
    late = process.at(3 * BLOCK + 5)  # forces four blocks at once
    again = DriftProcess(DRIFT_PRESETS["belt"].checked(), NOMINAL, 3)
    for frame in range(3 * BLOCK + 6):  # one frame at a time
        value = again.at(frame)
    assert value == late


@settings(max_examples=40, deadline=None)
@given(
    low=st.floats(1e-3, 10.0),
    span=st.floats(0.0, 100.0),
    step=st.floats(1e-3, 5.0),
    log=st.booleans(),
    hold=st.floats(1.0, 50.0),
    seed=st.integers(0, 2**32),
)
def test_schedules_stay_in_their_range(low, span, step, log, hold, seed):
    high = low + span
    drift = SensorDrift(
        noise_std=RandomWalk(low, high, step=step, log=log),
        clutter_rate=Steps(low, high, mean_hold=hold, log=log),
        p_detect=RandomWalk(0.0, 1.0, step=step),
    )
    v = _values(drift, seed, 2 * BLOCK + 3)
    assert np.all(v[0] >= low) and np.all(v[0] <= high)
    assert np.all(v[2] >= low) and np.all(v[2] <= high)
    assert np.all(v[1] >= 0) and np.all(v[1] <= 1)


def test_steps_hold_their_value_for_mean_hold_frames_on_average():
    v = _values(SensorDrift(clutter_rate=Steps(0.0, 10.0, mean_hold=50)), 0, 40 * BLOCK)[2]
    changes = np.count_nonzero(np.diff(v))
    assert 40 * BLOCK / changes == pytest.approx(50, rel=0.15)


def test_random_walk_moves_by_its_step():
    v = _values(SensorDrift(p_detect=RandomWalk(0.0, 1.0, step=0.01, start=0.5)), 0, BLOCK)[1]
    assert v[0] == pytest.approx(0.5, abs=0.05)
    assert np.std(np.diff(v)) == pytest.approx(0.01, rel=0.2)


def test_parameters_without_schedule_stay_nominal():
    v = _values(SensorDrift(noise_std=Steps(1e-5, 1e-3)), 0, 10)
    assert np.all(v[1] == NOMINAL.p_detect) and np.all(v[2] == NOMINAL.clutter_rate)


@pytest.mark.parametrize(
    ("drift", "message"),
    [
        ("nope", "unknown drift preset 'nope'"),
        ({"noise": {"kind": "steps", "low": 0, "high": 1}}, "no parameter \\['noise'\\]"),
        ({"noise_std": {"kind": "jump", "low": 0, "high": 1}}, "'kind' must be one of"),
        ({"noise_std": {"kind": "steps", "low": 0, "high": 1, "hold": 3}}, "has no field \\['hold'\\]"),
        (SensorDrift(p_detect=Steps(0.5, 1.5)), "leaves the valid range \\[0.0, 1.0\\]"),
        (SensorDrift(noise_std=Steps(2.0, 1.0)), "high must be >= low"),
        (SensorDrift(noise_std=Steps(0.0, 1.0, log=True)), "log-scaled schedule needs low > 0"),
        (SensorDrift(noise_std=Steps(0.1, 1.0, mean_hold=0.5)), "mean_hold must be >= 1"),
        (SensorDrift(noise_std=RandomWalk(0.1, 1.0, step=0.0)), "step must be"),
        (SensorDrift(noise_std=RandomWalk(0.1, 1.0, start=2.0)), "start must lie in"),
        (3, "drift must be a SensorDrift"),
    ],
)
def test_bad_drifts_are_refused_with_what_is_wrong(drift, message):
    with pytest.raises(ValueError, match=message):
        resolve_drift(drift)


def test_a_mapping_builds_the_same_drift_as_the_objects():
    mapping = {
        "noise_std": {"kind": "steps", "low": 5e-5, "high": 1e-3, "mean_hold": 200.0, "log": True},
        "p_detect": {"kind": "walk", "low": 0.85, "high": 1.0, "step": 0.01},
        "clutter_rate": {"kind": "steps", "low": 0.0, "high": 10.0, "mean_hold": 300.0},
    }
    assert resolve_drift(mapping) == resolve_drift("belt")


def _rollout(env: gym.Env, seed: int, frames: int) -> tuple[list, list]:
    obs, info = env.reset(seed=seed)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))  # type: ignore[attr-defined]
    seen, truth = [obs["detections"].copy()], [info.get("sensor")]
    for _ in range(frames):
        obs, _, terminated, _, info = env.step(report)
        seen.append(obs["detections"].copy())
        truth.append(info.get("sensor"))
        if terminated:
            break
    return seen, truth


@pytest.mark.parametrize("env_id", POINT_ENVS)
def test_point_envs_drift_reproducibly_with_the_nominal_spec(env_id):
    env = gym.make(env_id, drift=_drift_for(env_id))
    plain = gym.make(env_id)
    nominal = ("noise_std", "p_detect", "clutter_rate")  # the tracker is not told
    for name in nominal:
        assert getattr(env.unwrapped.sensor_spec, name) == getattr(plain.unwrapped.sensor_spec, name)
    a_obs, a_truth = _rollout(env, 5, 60)
    b_obs, b_truth = _rollout(env, 5, 60)
    assert all(np.array_equal(x, y) for x, y in zip(a_obs, b_obs, strict=True))
    assert a_truth == b_truth
    assert len({tuple(t.values()) for t in a_truth}) > 1  # it drifts
    assert set(a_truth[0]) == {"noise_std", "p_detect", "clutter_rate"}


@pytest.mark.parametrize("env_id", POINT_ENVS)
def test_without_drift_info_and_streams_are_unchanged(env_id):
    obs, truth = _rollout(gym.make(env_id), 2, 5)
    again, _ = _rollout(gym.make(env_id, drift=None), 2, 5)
    assert truth == [None] * len(truth)
    assert all(np.array_equal(x, y) for x, y in zip(obs, again, strict=True))


def test_the_drift_drives_the_detections():
    """Clutter steps show up in the detection count; the noise in the spread about the truth."""
    drift = SensorDrift(
        clutter_rate=Steps(0.0, 20.0, mean_hold=30), noise_std=Steps(1e-4, 1e-3, mean_hold=30)
    )
    env = gym.make("BeltSorter-v0", drift=drift, merge_touching=False)
    obs, info = env.reset(seed=0)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    clutter, rates, errors, noise = [], [], [], []
    for _ in range(300):
        ids = info["detection_ids"]
        clutter.append(np.count_nonzero((ids < 0) & (obs["mask"] == 1)))
        rates.append(info["sensor"]["clutter_rate"])
        truth = dict(zip(info["truth"]["ids"], info["truth"]["positions"], strict=True))
        real = [(obs["detections"][r], truth[i]) for r, i in enumerate(ids) if i >= 0]
        errors.append(np.mean([np.sum((z - x) ** 2) / 2 for z, x in real]))
        noise.append(info["sensor"]["noise_std"] ** 2)
        obs, _, _, _, info = env.step(report)
    assert np.corrcoef(clutter, rates)[0, 1] > 0.8
    assert np.corrcoef(errors, noise)[0, 1] > 0.8


def test_a_pickled_drifting_belt_continues_its_episode():
    env = gym.make("BeltSorter-v0", drift="belt").unwrapped
    env.reset(seed=1)
    report = empty_report(env.sensor_spec.max_tracks, (2,))
    for _ in range(300):  # past the first block of the schedule
        env.step(report)
    copy = pickle.loads(pickle.dumps(env))
    for _ in range(3):
        a, *_, info_a = env.step(report)
        b, *_, info_b = copy.step(report)
        assert np.array_equal(a["detections"], b["detections"])
        assert info_a["sensor"] == info_b["sensor"]
