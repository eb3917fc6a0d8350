"""Records, atomic writes, resume, tables, local engine parity and a killed run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib.image
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from track_apps.bench import Cell, expand, load_records, run_cell, run_cells, write_record
from track_apps.bench import runner as runner_mod
from track_apps.bench.cells import Group
from track_apps.cli.bench import main
from track_envs.wrappers import TrackingMetrics

ROOT = Path(__file__).resolve().parents[3]


def metrics_by_key(records: list[dict[str, Any]]) -> dict[str, dict[str, str]]:
    """Cell key → metrics as reprs (NaN equals NaN; floats compared bit for bit)."""
    return {r["key"]: {k: repr(float(v)) for k, v in r["metrics"].items()} for r in records}


def test_record_has_metrics_timings_and_versions():
    cell = Cell("BeltSorter-v0", "gnn", "kf-ca", 4, (("noise_std", 2e-4),), steps=30)
    record = run_cell(cell)
    env = TrackingMetrics(gym.make("BeltSorter-v0", noise_std=2e-4, max_episode_steps=30))
    agent = make_agent("gnn", predictor="kf-ca")
    obs, _ = env.reset(seed=4)
    agent.reset(env.unwrapped.sensor_spec, seed=4)
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            break
    assert record["metrics"] == info["episode_metrics"]  # the plain loop, same numbers
    assert record["key"] == cell.key and Cell.from_dict(record["cell"]) == cell
    assert {"wall_s", "episode_s", "frames", "frames_per_s"} <= set(record["timing"])
    assert record["timing"]["frames"] == 30 and record["timing"]["frames_per_s"] > 0
    assert set(record["versions"]) == {
        "track-envs",
        "numpy",
        "gymnasium",
        "pymunk",
        "track-envs-source",
        "python",
    }
    assert json.loads(json.dumps(record, allow_nan=False)) == record  # strict JSON, nothing lost


def test_nan_metrics_round_trip(tmp_path):
    record = run_cell(Cell("SineTarget-v0", "pf", "-", 0, steps=20))
    assert record["metrics"]["occlusion_error"] == "nan"  # no occlusion in 20 frames
    write_record(tmp_path, record)
    (loaded,) = load_records(tmp_path)
    assert loaded["metrics"]["occlusion_error"] != loaded["metrics"]["occlusion_error"]


def test_write_is_atomic(tmp_path, monkeypatch):
    record = run_cell(Cell("SineTarget-v0", "pf", "-", 0, steps=10))

    def broken_dump(obj, fh, **kwargs):
        fh.write('{"schema": 1, "key": "trunc')  # half a record, then the process "dies"
        raise KeyboardInterrupt

    monkeypatch.setattr(runner_mod.json, "dump", broken_dump)
    with pytest.raises(KeyboardInterrupt):
        write_record(tmp_path, record)
    assert list(tmp_path.iterdir()) == []  # neither a partial record nor a temporary file


def test_rerun_computes_nothing_new(tmp_path, small_cells):
    first = run_cells(small_cells, tmp_path, workers=1, progress=False)
    assert (first.computed, first.skipped) == (len(small_cells), 0)
    stamps = {p.name: p.stat().st_mtime_ns for p in tmp_path.glob("*.json")}
    second = run_cells(small_cells, tmp_path, workers=1, progress=False)
    assert (second.computed, second.skipped) == (0, len(small_cells))
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.glob("*.json")} == stamps
    # one more seed: only that cell runs
    third = run_cells([*small_cells, Cell("SineTarget-v0", "pf", "-", 9, steps=30)], tmp_path, workers=1)
    assert third.computed == 1


def test_local_pool_equals_in_process(tmp_path, small_cells):
    run_cells(small_cells, tmp_path / "one", workers=1, progress=False)
    run_cells(small_cells, tmp_path / "two", workers=2, progress=False)
    one, two = load_records(tmp_path / "one"), load_records(tmp_path / "two")
    assert len(one) == len(small_cells)
    assert metrics_by_key(one) == metrics_by_key(two)
    assert [r["cell"] for r in one] == [r["cell"] for r in two]


def test_tables_rebuilds_the_tables_and_plots(tmp_path, capsys):
    out = tmp_path / "sweep"
    args = ["run", "--envs", "SineTarget-v0", "--agents", "gnn,pf", "--predictors", "kf-cv", "--seeds", "2"]
    args += ["--steps", "25", "--sweep", "p_detect=0.9,0.6", "--workers", "1", "--out", str(out)]
    assert main(args) == 0
    first = capsys.readouterr().out
    assert "SineTarget-v0" in first and "±" in first and "*" in first
    for name in ("results.md", "summary.csv", "records.csv"):
        (out / name).unlink()
    for png in (out / "plots").iterdir():
        png.unlink()
    assert main(["tables", str(out)]) == 0
    assert "p_detect=0.6" in capsys.readouterr().out
    md = (out / "results.md").read_text()
    assert "## SineTarget-v0" in md and "**" in md and "gnn" in md
    summary = (out / "summary.csv").read_text().splitlines()
    assert summary[0] == "env_id,params,agent,predictor,n,metric,mean,std" and len(summary) > 10
    assert len((out / "records.csv").read_text().splitlines()) == 1 + 8
    plots = {p.name for p in (out / "plots").iterdir()}
    assert plots == {"SineTarget-v0_bars.png", "SineTarget-v0_p_detect_sweep.png"}
    for name in plots:
        image = matplotlib.image.imread(out / "plots" / name)
        assert image.shape[0] > 100 and image.shape[1] > 100 and image.std() > 0  # a drawn figure


def test_tables_of_an_empty_dir_fails(tmp_path, capsys):
    assert main(["tables", str(tmp_path)]) == 2
    assert "no records" in capsys.readouterr().err


def test_killed_run_resumes_with_only_the_missing_cells(tmp_path):
    """SIGKILL the whole CLI (driver and pool workers) after its first record, then rerun."""
    flags = ["--envs", "BeltSorter-v0", "--agents", "gnn", "--predictors", "kf-ca", "--seeds", "12"]
    flags += ["--steps", "120"]
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "track_apps.bench", "run", *flags, "--workers", "2", "--out", str(out)]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        deadline = time.monotonic() + 60
        while not list(out.glob("*.json")) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.002)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    finished = list(out.glob("*.json"))
    cells = expand([Group(("BeltSorter-v0",), ("gnn",), ("kf-ca",), tuple(range(12)), 1, 120)])
    assert 1 <= len(finished) < len(cells), "the kill should land mid-run"
    assert len(load_records(out)) == len(finished)  # every record that exists is whole

    resumed = run_cells(cells, out, workers=1, progress=False)
    assert resumed.computed == len(cells) - len(finished) and resumed.skipped == len(finished)
    clean = run_cells(cells, tmp_path / "clean", workers=1, progress=False)
    assert clean.computed == len(cells)
    assert metrics_by_key(load_records(out)) == metrics_by_key(load_records(tmp_path / "clean"))


def test_records_from_other_versions_are_recomputed(tmp_path):
    """Regression: a stale record (other package versions) counted as finished on resume."""
    import json

    from track_apps.bench.cells import Cell
    from track_apps.bench.runner import is_finished, run_cell, write_record

    cell = Cell(env_id="SineTarget-v0", agent="detections", predictor="-", seed=0, steps=10)
    record = run_cell(cell)
    write_record(tmp_path, record)
    assert is_finished(tmp_path, cell)
    path = tmp_path / cell.filename
    stale = json.loads(path.read_text())
    stale["versions"]["numpy"] = "0.0-stale"
    path.write_text(json.dumps(stale))
    assert not is_finished(tmp_path, cell)


def test_source_digest_changes_with_any_source_file(tmp_path):
    """Regression: an edited checkout kept its version number and reused stale records."""
    from track_apps.bench.runner import source_digest

    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "a.py").write_text("x = 1\n")
    (package / "sub" / "b.py").write_text("y = 2\n")
    (package / "notes.txt").write_text("not source")
    first = source_digest([package])
    assert source_digest([package]) == first
    (package / "notes.txt").write_text("still not source")
    assert source_digest([package]) == first
    (package / "sub" / "b.py").write_text("y = 3\n")
    assert source_digest([package]) != first
