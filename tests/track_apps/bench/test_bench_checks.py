"""Every cell's env and agent are built before the first cell runs; a bad one is one error line."""

from __future__ import annotations

from dataclasses import replace

import pytest

from track_apps.bench import Cell, expand, load_suite, run_cell, run_cells
from track_apps.bench.runner import CellError, check_cells
from track_apps.cli.bench import main

BELT = ["run", "--envs", "BeltSorter-v0", "--agents", "detections", "--seeds", "2", "--steps", "5"]


@pytest.mark.parametrize(
    ("sweep", "says"),
    [
        ("noise_std=0,abc", "BeltSorter-v0 noise_std='abc': noise_std must be a number"),
        ("noise_std=0,-1", "cell BeltSorter-v0 [noise_std=-1, steps=5] detections seed 0: env: ValueError"),
    ],
)  # fmt: skip
def test_a_bad_sweep_value_stops_the_run_before_any_cell(tmp_path, capsys, sweep, says):
    """Regression: noise_std=-1 failed in a pool worker with a long traceback after other cells ran."""
    out = tmp_path / "out"
    assert main([*BELT, "--sweep", sweep, "--workers", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0], err
    assert not list(out.glob("*.json")) if out.exists() else True  # no cell ran


def test_a_bad_agent_kwarg_names_the_cell_and_the_agent(tmp_path, capsys):
    args = ["run", "--envs", "SineTarget-v0", "--agents", "gnn", "--predictors", "kf-cv", "--seeds", "1"]
    assert main([*args, "--agent-kwargs", "p_gate=0.9,gate=3", "--out", str(tmp_path / "o")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(
        "track bench run: error: cell SineTarget-v0 [steps=100, agent.gate=3, agent.p_gate=0.9] gnn/kf-cv"
    )
    assert ": agent: " in line and "gate" in line and line.endswith("(no cell was run)")
    assert not (tmp_path / "o").exists()


def test_check_cells_builds_each_distinct_argument_set_once(tmp_path):
    good = Cell("SineTarget-v0", "detections", "-", 0, steps=5)
    cells = [replace(good, seed=s) for s in range(4)] + [replace(good, agent="pf", seed=1)]
    assert check_cells(cells) == 1 + 2  # one env setting, two agents
    bad = replace(good, env_kwargs=(("p_detect", 1.5),), seed=3)
    with pytest.raises(
        CellError, match=r"^cell SineTarget-v0 \[p_detect=1.5, steps=5\] detections seed 3: env: "
    ):
        check_cells([*cells, bad])
    with pytest.raises(CellError):
        run_cells([good, bad], tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out").exists()  # the good cell did not run either


def test_quick_suite_replay_seeds_differ():
    """Regression: BeltReplay-v0 has no noise by default, so its two quick seeds were identical (± 0)."""
    cells = [
        replace(c, steps=20)
        for c in expand(load_suite("quick"))
        if c.env_id == "BeltReplay-v0" and c.agent == "gnn" and c.predictor == "kf-cv"
    ]
    assert [c.seed for c in cells] == [0, 1]
    first, second = (run_cell(c)["metrics"] for c in cells)
    assert first["gospa"] != second["gospa"]
