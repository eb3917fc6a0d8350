"""Every example script runs (with small budgets)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

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
