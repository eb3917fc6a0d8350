"""The grid suite for track bench, the best fixed setting of its records, the paired statistics."""

from __future__ import annotations

import json

import numpy as np
import pytest

from track_apps.bench.cells import expand, load_suite
from track_apps.cli.tune import main
from track_apps.tuning.env import HELD_OUT_SEEDS
from track_apps.tuning.evaluate import GRID, best_fixed, grid_settings, held_out_seeds, paired


def test_the_grid_suite_is_a_track_bench_suite_of_every_setting(tmp_path):
    out = tmp_path / "grid.toml"
    assert main(["grid-suite", "--seeds", "0:3", "--steps", "50", "--out", str(out)]) == 0
    groups = load_suite(str(out))
    n_settings = len(grid_settings())
    assert (
        len(groups)
        == n_settings
        == len(GRID["p_gate"]) * len(GRID["recovery_inflation"]) * len(GRID["noise_scale"])
    )
    cells = expand(groups)
    assert len(cells) == 3 * n_settings
    assert (
        dict(cells[0].env_kwargs) == {"drift": "belt", "max_tracks": 512, "max_targets": 512}
        and cells[0].steps == 50
    )


def _record(seed, errors, **setting):
    return {
        "cell": {"seed": seed, "agent_kwargs": {**setting, "predict_sorting": False}},
        "metrics": {"e1": errors / 100, "n_tracks": 100.0, "e2": 0.0, "n_particles": 50.0},
    }


def test_best_fixed_takes_the_fewest_mean_errors():
    records = [_record(s, 10 + s, p_gate=0.99) for s in range(3)]
    records += [_record(s, 5 + 3 * s, p_gate=0.999) for s in range(3)]
    result = best_fixed(records, knobs=("p_gate",))
    assert result["best"] == {"p_gate": 0.999}  # mean 8 against 11
    assert [r["mean"] for r in result["rows"]] == sorted(r["mean"] for r in result["rows"])


def test_best_fixed_refuses_unequal_seed_sets():
    records = [_record(0, 1, p_gate=0.99), _record(1, 1, p_gate=0.999)]
    with pytest.raises(ValueError, match="different seeds"):
        best_fixed(records, knobs=("p_gate",))


def test_paired_statistics():
    r = paired([8, 9, 10, 12], [10, 10, 10, 10])
    assert r["wins"] == 2 and r["losses"] == 1 and r["n"] == 4
    assert r["mean_diff"] == pytest.approx(-0.25)
    assert r["improvement"] == pytest.approx(0.025)
    assert 0 < r["wilcoxon_p"] <= 1


def test_held_out_seeds_are_never_drawn_by_training():
    assert min(held_out_seeds(10)) >= HELD_OUT_SEEDS


def test_evaluate_cli_prints_the_paired_comparisons(tmp_path, capsys):
    out = tmp_path / "eval.json"
    argv = [
        "evaluate",
        "--seeds",
        "2",
        "--fixed",
        "p_gate=0.9999",
        "--env-kwargs",
        "frames_per_step=2,episode_steps=2",
    ]
    assert main([*argv, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "ppo vs best-fixed" in text and "ppo vs nis-rule" in text
    result = json.loads(out.read_text())
    assert set(result["errors"]) == {"ppo", "nis-rule", "gnn-defaults", "best-fixed"}


def test_a_policy_with_other_knob_ranges_is_refused():
    import gymnasium as gym

    from track_apps.tuning import FixedPolicy
    from track_apps.tuning.evaluate import episode_errors

    env = gym.make("GateTuning-v0", frames_per_step=2, episode_steps=2)
    policy = FixedPolicy(ranges={"noise_scale": (0.5, 8.0)})
    with pytest.raises(ValueError, match="differ from the env's"):
        episode_errors(env, policy, 0)


def test_episode_errors_traces_the_errors_and_the_true_sensor():
    import gymnasium as gym

    from track_apps.tuning import FixedPolicy
    from track_apps.tuning.evaluate import episode_errors

    env = gym.make("GateTuning-v0", frames_per_step=3, episode_steps=4)
    out = episode_errors(env, FixedPolicy({"p_gate": 0.9}), 3)
    assert len(out["errors_so_far"]) == len(out["knobs"]) == len(out["sensor"]) == 4
    assert out["errors_so_far"][-1] == out["errors"] and out["errors"] == -out["return"]
    assert np.all(np.diff(out["errors_so_far"]) >= 0)
    assert set(out["sensor"][0]) == {"noise_std", "p_detect", "clutter_rate"}
    quiet = gym.make("GateTuning-v0", frames_per_step=3, episode_steps=2, drift=None)
    assert episode_errors(quiet, FixedPolicy(), 3)["sensor"] == []
