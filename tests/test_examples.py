"""Every example script runs (with small budgets)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
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


def test_pf_paper_figures_quick_grid_writes_three_figures(tmp_path, capsys):
    out = load("pf_paper_figures").main(["--quick", "--runs", "2", "--out", str(tmp_path)])
    assert len(out["files"]) == 3
    for f in out["files"]:
        assert Path(f).stat().st_size > 1000
    assert out["error_grid"].shape == (2, 2) and np.isfinite(out["error_grid"]).all()
    assert out["sigma_n_grid"].shape == (2, 2)
    # p_detect = 1 tracks better than p_detect = 0.5 at the same σ_p
    assert np.all(out["error_grid"][1] < out["error_grid"][0])
    assert "Fig. 7" in capsys.readouterr().out


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
