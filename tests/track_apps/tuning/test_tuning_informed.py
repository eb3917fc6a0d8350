"""The sensor-informed reference: its constant-sensor table, interpolation, and the policy."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_apps.tuning  # noqa: F401
from track_apps.cli.tune import main
from track_apps.tuning import FixedPolicy
from track_apps.tuning.evaluate import episode_errors
from track_apps.tuning.informed import (
    INFORMED_GRID,
    SensorInformedPolicy,
    SensorTable,
    constant_drift,
    default_states,
    sensor_table,
)
from track_envs.envs.drift import DRIFT_PRESETS

SHORT = {"frames_per_step": 3}
STEPS = 3
SEED = 5
STATES = {"noise_std": (1e-4, 8e-4), "p_detect": (0.9,), "clutter_rate": (0.0, 8.0)}
SETTINGS = [
    {"p_gate": 0.7, "recovery_inflation": 1.0, "noise_scale": 32.0},
    {"p_gate": 0.999, "recovery_inflation": 25.0, "noise_scale": 1.0},
]


def _table(errors: np.ndarray) -> SensorTable:
    return SensorTable(STATES, SETTINGS, errors, (SEED,), STEPS)


def test_default_states_span_the_belt_drift():
    states = default_states("belt", n_noise=4)
    belt = DRIFT_PRESETS["belt"]
    assert states["noise_std"][0] == pytest.approx(belt.noise_std.low)
    assert states["noise_std"][-1] == pytest.approx(belt.noise_std.high)
    ratios = np.diff(np.log(states["noise_std"]))
    assert np.allclose(ratios, ratios[0])  # log-spaced
    assert states["p_detect"] == (belt.p_detect.low, belt.p_detect.high)
    assert states["clutter_rate"] == (belt.clutter_rate.low, belt.clutter_rate.high)
    with pytest.raises(ValueError, match="unknown drift preset 'nope'"):
        default_states("nope")


def test_constant_drift_holds_the_sensor():
    env = gym.make("GateTuning-v0", drift=constant_drift(3e-4, 0.9, 2.0), episode_steps=4, **SHORT)
    env.reset(seed=SEED)
    seen = []
    for _ in range(4):
        env.step(env.action_space.sample() * 0)
        seen.append(env.unwrapped.true_sensor())
    assert all(s == pytest.approx({"noise_std": 3e-4, "p_detect": 0.9, "clutter_rate": 2.0}) for s in seen)


def test_each_cell_is_the_fixed_episode_at_that_constant_sensor():
    table = sensor_table([SEED], STEPS, states=STATES, grid={"p_gate": (0.7, 0.999)}, env_kwargs=SHORT)
    assert table.errors.shape == (2, 1, 2, 2)
    for i, noise in enumerate(STATES["noise_std"]):
        for k, clutter in enumerate(STATES["clutter_rate"]):
            env = gym.make(
                "GateTuning-v0", drift=constant_drift(noise, 0.9, clutter), episode_steps=STEPS, **SHORT
            )
            for j, setting in enumerate(table.settings):
                expected = episode_errors(env, FixedPolicy(setting), SEED)["errors"]
                assert table.errors[i, 0, k, j] == expected


def test_interpolation_is_multilinear_in_log_noise_and_clamped():
    errors = np.zeros((2, 1, 2, 2))
    errors[:, 0, :, 0] = [[10.0, 30.0], [50.0, 70.0]]  # setting 0
    errors[:, 0, :, 1] = 40.0  # setting 1: flat
    table = _table(errors)
    mid_noise = float(np.sqrt(1e-4 * 8e-4))  # half-way in log
    at = table.expected_errors({"noise_std": mid_noise, "p_detect": 0.5, "clutter_rate": 4.0})
    assert at == pytest.approx([40.0, 40.0])
    corner = {"noise_std": 1e-4, "p_detect": 0.9, "clutter_rate": 0.0}
    assert table.expected_errors(corner) == pytest.approx([10.0, 40.0]) and table.best(corner) == 0
    beyond = {"noise_std": 1.0, "p_detect": 1.0, "clutter_rate": 100.0}  # clamped to the far corner
    assert table.expected_errors(beyond) == pytest.approx([70.0, 40.0]) and table.best(beyond) == 1
    with pytest.raises(ValueError, match="lack"):
        table.expected_errors({"noise_std": 1e-4})


def test_the_policy_plays_the_best_setting_of_the_true_sensor():
    errors = np.zeros((2, 1, 2, 2))
    errors[..., 0] = [[[1.0, 9.0]], [[9.0, 9.0]]]  # setting 0 best only at low noise, no clutter
    errors[..., 1] = 5.0
    table = _table(errors)
    env = gym.make("GateTuning-v0", episode_steps=6, **SHORT)
    policy = SensorInformedPolicy(table).bind(env)
    obs, _ = env.reset(seed=SEED)
    for _ in range(6):
        sensor = env.unwrapped.true_sensor()
        action, _ = policy.predict(obs)
        expected = table.best(sensor)
        assert policy.choices[-1] == expected
        np.testing.assert_array_equal(action, FixedPolicy(SETTINGS[expected]).action)
        obs, *_ = env.step(action)


def test_a_table_with_one_setting_plays_as_that_fixed_setting():
    table = SensorTable(STATES, SETTINGS[:1], np.ones((2, 1, 2, 1)), (SEED,), STEPS)
    env = gym.make("GateTuning-v0", episode_steps=4, **SHORT)
    informed = episode_errors(env, SensorInformedPolicy(table), SEED)
    fixed = episode_errors(env, FixedPolicy(SETTINGS[0]), SEED)
    assert informed["errors"] == fixed["errors"] and informed["knobs"] == fixed["knobs"]


def test_table_round_trips_and_bad_tables_are_named(tmp_path):
    table = _table(np.arange(8.0).reshape(2, 1, 2, 2))
    path = table.save(tmp_path / "t.json")
    back = SensorTable.load(path)
    assert back.states == table.states and back.settings == table.settings
    np.testing.assert_array_equal(back.errors, table.errors)
    with pytest.raises(ValueError, match=r"shape \(2, 1, 2, 2\)"):
        SensorTable(STATES, SETTINGS, np.zeros((2, 2)), (SEED,), STEPS)
    with pytest.raises(ValueError, match="increasing"):
        SensorTable({**STATES, "clutter_rate": (8.0, 0.0)}, SETTINGS, np.zeros((2, 1, 2, 2)), (SEED,), STEPS)
    with pytest.raises(ValueError, match="must be"):
        SensorTable({"p_detect": (1.0,)}, SETTINGS, np.zeros((1, 2)), (SEED,), STEPS)
    (tmp_path / "bad.json").write_text('{"version": 99}')
    with pytest.raises(ValueError, match="not a sensor table"):
        SensorTable.load(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="cannot read"):
        SensorTable.load(tmp_path / "missing.json")


def test_the_policy_needs_a_bound_drifting_env():
    policy = SensorInformedPolicy(_table(np.zeros((2, 1, 2, 2))))
    with pytest.raises(RuntimeError, match="bind"):
        policy.predict(np.zeros(12, np.float32))
    env = gym.make("GateTuning-v0", drift=None, episode_steps=2, **SHORT)
    with pytest.raises(RuntimeError, match="no true sensor"):
        episode_errors(env, policy, SEED)
    with pytest.raises(ValueError, match="drift"):
        sensor_table([SEED], STEPS, states=STATES, env_kwargs={"drift": None})
    with pytest.raises(ValueError, match="seed"):
        sensor_table([], STEPS, states=STATES)


def test_the_default_grid_holds_the_best_fixed_setting():
    settings = {
        (g, i, n)
        for g in INFORMED_GRID["p_gate"]
        for i in INFORMED_GRID["recovery_inflation"]
        for n in INFORMED_GRID["noise_scale"]
    }
    assert (0.7, 1.0, 32.0) in settings


def test_cli_writes_a_table_and_evaluates_it(tmp_path, capsys):
    out = tmp_path / "table.json"
    kwargs = "frames_per_step=2"
    assert (
        main(
            [
                "sensor-grid",
                "--seeds",
                "0:1",
                "--steps",
                "1",
                "--noise-states",
                "2",
                "--env-kwargs",
                kwargs,
                "--out",
                str(out),
            ]
        )
        == 0
    )
    table = SensorTable.load(out)
    assert table.errors.shape == (2, 2, 2, len(table.settings))
    assert "best setting over all states" in capsys.readouterr().out
    result = tmp_path / "eval.json"
    assert (
        main(
            [
                "evaluate",
                "--seeds",
                "2",
                "--informed",
                str(out),
                "--fixed",
                "p_gate=0.7",
                "--env-kwargs",
                "frames_per_step=2,episode_steps=2",
                "--out",
                str(result),
            ]
        )
        == 0
    )
    assert "informed vs best-fixed" in capsys.readouterr().out
    assert main(["evaluate", "--informed", str(out), "--no-drift"]) == 2
    assert "nothing to follow" in capsys.readouterr().err
