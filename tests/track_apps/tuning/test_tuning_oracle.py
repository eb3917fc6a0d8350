"""The clairvoyant lookahead oracle: greedy choices on env copies, a fixed policy when alone."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import track_apps.tuning  # noqa: F401
from track_apps.tuning import FixedPolicy
from track_apps.tuning.evaluate import episode_errors, evaluate
from track_apps.tuning.oracle import ORACLE_GRID, LookaheadOracle, reseed_in_place

SHORT = {"frames_per_step": 3, "episode_steps": 4}
SEED = 7


def _env():
    return gym.make("GateTuning-v0", **SHORT)


def test_the_default_candidates_are_the_oracle_grid():
    oracle = LookaheadOracle()
    assert len(oracle.candidates) == int(np.prod([len(v) for v in ORACLE_GRID.values()]))


def test_one_candidate_plays_as_that_fixed_setting():
    setting = {"p_gate": 0.99, "recovery_inflation": 1.0, "noise_scale": 4.0}
    env = _env()
    alone = episode_errors(env, LookaheadOracle([setting], horizon=1), SEED)
    fixed = episode_errors(env, FixedPolicy(setting), SEED)
    assert alone["errors"] == fixed["errors"] and alone["knobs"] == fixed["knobs"]


def test_each_choice_has_the_best_one_step_reward_among_the_candidates():
    candidates = [
        {"p_gate": 0.9, "noise_scale": 16.0},
        {"p_gate": 0.999999, "noise_scale": 0.25},
        {"p_gate": 0.999, "noise_scale": 1.0},
    ]
    env = gym.make("GateTuning-v0", frames_per_step=10, episode_steps=6)
    oracle = LookaheadOracle(candidates, horizon=1).bind(env)
    obs, _ = env.reset(seed=SEED)
    done = False
    while not done:
        rewards = []
        for a in oracle._actions:
            twin = copy.deepcopy(env.unwrapped)
            rewards.append(twin.step(a)[1])
        action, _ = oracle.predict(obs)
        obs, reward, terminated, truncated, _ = env.step(action)
        assert reward == max(rewards)
        done = terminated or truncated
    assert len(oracle.choices) == 6


def test_a_resampled_future_changes_the_copies_not_the_played_episode():
    setting = {"p_gate": 0.99, "recovery_inflation": 1.0, "noise_scale": 4.0}
    env = _env()
    alone = episode_errors(env, LookaheadOracle([setting], horizon=1, resample_future=True), SEED)
    fixed = episode_errors(env, FixedPolicy(setting), SEED)
    assert alone["errors"] == fixed["errors"] and alone["knobs"] == fixed["knobs"]


def test_reseeding_a_copy_draws_other_detections_and_keeps_the_present():
    env = gym.make("GateTuning-v0", frames_per_step=10, episode_steps=6)
    env.reset(seed=SEED)
    env.step(np.zeros(3, np.float32))
    same, other = copy.deepcopy(env.unwrapped), copy.deepcopy(env.unwrapped)
    reseed_in_place(other.base.unwrapped.np_random, 123)
    assert other.base.unwrapped.world.digest() == env.unwrapped.base.unwrapped.world.digest()  # same present
    for twin in (env.unwrapped, same, other):
        twin.step(np.zeros(3, np.float32))
    dets = [t._obs["detections"][t._obs["mask"] == 1] for t in (env.unwrapped, same, other)]
    np.testing.assert_array_equal(dets[0], dets[1])
    assert dets[0].shape != dets[2].shape or not np.array_equal(dets[0], dets[2])


def test_several_futures_average_the_candidates_returns():
    candidates = [{"p_gate": 0.7, "noise_scale": 32.0}, {"p_gate": 0.999, "noise_scale": 1.0}]
    env = gym.make("GateTuning-v0", frames_per_step=5, episode_steps=3)
    oracle = LookaheadOracle(candidates, horizon=1, resample_future=True, seed=4, futures=3).bind(env)
    obs, _ = env.reset(seed=SEED)
    draws = np.random.default_rng(4)
    for _ in range(3):
        seeds = draws.integers(2**63 - 1, size=3)
        means = []
        for a in oracle._actions:
            rewards = []
            for s in seeds:
                twin = copy.deepcopy(env.unwrapped)
                reseed_in_place(twin.base.unwrapped.np_random, int(s))
                rewards.append(twin.step(a)[1])
            means.append(np.mean(rewards))
        action, _ = oracle.predict(obs)
        assert oracle.choices[-1] == int(np.argmax(means))
        obs, *_ = env.step(action)


def test_a_resampling_oracle_is_deterministic_per_seed():
    candidates = [{"p_gate": 0.7, "noise_scale": 32.0}, {"p_gate": 0.999, "noise_scale": 1.0}]
    env = gym.make("GateTuning-v0", frames_per_step=5, episode_steps=5)
    runs = []
    for _ in range(2):
        oracle = LookaheadOracle(candidates, horizon=1, resample_future=True, seed=3)
        runs.append((episode_errors(env, oracle, SEED)["errors"], list(oracle.choices)))
    assert runs[0] == runs[1]


def test_bad_oracle_arguments_are_named():
    with pytest.raises(ValueError, match="horizon"):
        LookaheadOracle(horizon=0)
    with pytest.raises(ValueError, match="seed"):
        LookaheadOracle(resample_future=True, seed=-1)
    with pytest.raises(ValueError, match="futures"):
        LookaheadOracle(resample_future=True, futures=0)
    with pytest.raises(ValueError, match="at least one"):
        LookaheadOracle([])
    with pytest.raises(ValueError, match="unknown knob \\['gate'\\]; the knobs are"):
        LookaheadOracle([{"gate": 0.9}]).bind(_env())
    with pytest.raises(RuntimeError, match="bind"):
        LookaheadOracle().predict(np.zeros(12, np.float32))


def test_evaluate_in_worker_processes_equals_one_process():
    policies = {
        "fixed": FixedPolicy({"p_gate": 0.99}),
        "oracle": LookaheadOracle([{"noise_scale": 1.0}, {"noise_scale": 16.0}], horizon=1),
    }
    seeds = [SEED, SEED + 1]
    assert evaluate(policies, seeds, SHORT, workers=2) == evaluate(policies, seeds, SHORT)


def test_evaluate_cli_plays_the_oracle(tmp_path, capsys):
    from track_apps.cli.tune import main

    out = tmp_path / "eval.json"
    argv = ["evaluate", "--seeds", "1", "--oracle", "--oracle-horizon", "1", "--fixed", "p_gate=0.99"]
    assert main([*argv, "--env-kwargs", "frames_per_step=2,episode_steps=2", "--out", str(out)]) == 0
    assert "oracle vs best-fixed" in capsys.readouterr().out
    import json

    assert "oracle" in json.loads(out.read_text())["errors"]


def test_oracle_resample_flag_takes_an_optional_number_of_futures():
    from track_apps.cli.tune import build_parser

    parse = build_parser().parse_args
    assert parse(["evaluate", "--oracle"]).oracle_resample == 0
    assert parse(["evaluate", "--oracle", "--oracle-resample"]).oracle_resample == 1
    assert parse(["evaluate", "--oracle", "--oracle-resample", "3"]).oracle_resample == 3
