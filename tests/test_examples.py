"""Every example script runs (with small budgets)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_belt_sorter_episode_prints_metrics_and_writes_a_png(tmp_path, capsys):
    png = tmp_path / "frame.png"
    summary = load("belt_sorter_episode").main(["--steps", "40", "--png", str(png)])
    assert summary["frames"] == 40
    assert summary["mean particles in window"] > 10
    assert summary["e_mean"] < 0.05 and summary["MOTA"] > 0.9
    assert png.stat().st_size > 1000
    assert "mean GOSPA" in capsys.readouterr().out


def test_pf_paper_figures_quick_runs_every_experiment_with_both_filters(tmp_path, capsys):
    learned = "lstm"
    out = load("pf_paper_figures").main(["--quick", "--runs", "8", "--out", str(tmp_path)])
    assert [Path(f).name for f in out["files"]] == [
        "fig3_tracks.png",
        "fig4_error_grid.png",
        "fig5_error_sigma_n.png",
        "fig6_occlusion_example.png",
        "fig7_occlusion.png",
        "fig8_piecewise.png",
    ]
    for f in out["files"]:
        assert Path(f).stat().st_size > 1000
    for key in ("fig4", "fig5"):
        assert set(out[f"{key}_error"]) == {"brownian", learned}
        assert out[f"{key}_gain"].shape == (2, 2) and np.isfinite(out[f"{key}_gain"]).all()
    brownian = out["fig4_error"]["brownian"]
    # p_detect = 1 tracks better than p_detect = 0.3 at the same σ_p
    assert np.all(brownian[1] < brownian[0])
    # the LSTM-PF gains > 60% over the Brownian PF at low p_d and low σ_p (84-89% over seeds 0-3), and
    # is better in every cell of the N × σ_p grid (14% in its worst cell over those seeds)
    assert out["fig4_gain"][0, 0] > 60, out["fig4_gain"]
    assert np.all(out["fig5_gain"] > 0), out["fig5_gain"]
    assert out["fig7_lost"]["brownian"].shape == (2,)
    tables = (tmp_path / "tables.md").read_text()
    assert tables.count("| claim | paper | ours |") == 1 and len(out["claims"]) >= 10
    assert "Exp. 5 / Fig. 8" in capsys.readouterr().out


def test_track_any_env_runs_every_family(tmp_path, capsys):
    example = load("track_any_env")
    poses = example.main(["--env", "KeypointWalkers-v0", "--steps", "30", "--png", str(tmp_path / "p.png")])
    assert 0 < poses["mota"] <= 1 and (tmp_path / "p.png").stat().st_size > 1000
    single = example.main(
        ["--env", "SineTarget-v0", "--agent", "pf", "--steps", "50", "--kwargs", "p_detect=1.0"]
    )
    assert single["mean_error"] < 1.0
    belt = example.main(["--env", "BeltReplay-v0", "--predictor", "kf-cv", "--steps", "40"])
    assert belt["e2"] < 0.05
    assert "SineTarget-v0 + pf" in capsys.readouterr().out


def test_gate_tuning_trace_plays_the_policies_on_one_episode(tmp_path, capsys):
    import gymnasium as gym

    from agents.tuning import FixedPolicy
    from agents.tuning.evaluate import episode_errors
    from agents.tuning.informed import SensorTable

    states = {"noise_std": (1e-4, 1e-3), "p_detect": (0.9,), "clutter_rate": (0.0,)}
    table = SensorTable(states, [{"p_gate": 0.9}], np.ones((2, 1, 1, 1)), (0,), 1).save(tmp_path / "t.json")
    png = tmp_path / "trace.png"
    out = load("gate_tuning_trace").main(["--steps", "4", "--table", str(table), "--png", str(png)])
    assert set(out["errors"]) == {"PPO", "best fixed", "sensor-informed"}
    assert png.stat().st_size > 1000
    fixed = out["traces"]["best fixed"]
    assert len(fixed["errors"]) == 4 and np.all(np.diff(fixed["errors"]) >= 0)
    np.testing.assert_allclose(out["traces"]["sensor-informed"]["p_gate"], 0.9, rtol=1e-5)
    env = gym.make("GateTuning-v0", episode_steps=4)
    expected = episode_errors(
        env, FixedPolicy({"p_gate": 0.7, "recovery_inflation": 1.0, "noise_scale": 32.0}), 10**9
    )
    assert out["errors"]["best fixed"] == expected["errors"]
    assert "association errors" in capsys.readouterr().out


def test_extend_env_registers_a_contract_conforming_env_that_gnn_tracks(capsys):
    metrics = load("extend_env").main(["--steps", "40"])
    assert 0.5 < metrics["mota"] <= 1 and metrics["idf1"] > 0.7
    assert "CirclingTargets-v0: 40 frames" in capsys.readouterr().out


def test_extend_env_rejects_a_bad_argument_by_name():
    module = load("extend_env")
    with pytest.raises(ValueError, match=r"num_targets must be in 1\.\.32, got 0"):
        module.CirclingTargetsEnv(num_targets=0)


def test_extend_metric_is_scored_beside_the_default_metrics():
    metrics = load("extend_metric").main(["--steps", "60"])
    assert 0.5 < metrics["coverage"] < 1 and metrics["rmse"] > 0  # SineTarget-v0's own metrics too


def test_extend_metric_coverage_closed_form():
    coverage = load("extend_metric").Coverage(radius=1.0)
    truth = {"positions": np.array([[0.0, 0.0], [5.0, 0.0], [9.0, 9.0]]), "visible": np.array([1, 1, 0])}
    near = {"positions": np.array([[0.5, 0.0], [5.0, 0.9], [0.0, 0.0]]), "mask": np.array([1, 1, 0])}
    far = {"positions": np.array([[0.5, 0.0], [7.0, 0.0]]), "mask": np.array([1, 1])}
    coverage.update(truth, np.array([-1]), near)  # both visible targets within 1
    coverage.update(truth, np.array([-1]), far)  # the second is 2 away
    coverage.update({"positions": np.zeros((1, 2)), "visible": np.array([0])}, np.array([-1]), far)
    assert coverage.compute() == {"coverage": 2 / 3}
