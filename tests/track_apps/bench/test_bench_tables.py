"""Table rows (what is pooled), skipped records, and plot axes."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pytest
from matplotlib.container import ErrorbarContainer

from track_apps.bench import Cell, aggregate, load_records, run_cell, write_record
from track_apps.bench.runner import SkippedRecordWarning, scan_records
from track_apps.bench.tables import Row, axis_scale, bar_figure, error_band, sweep_figure
from track_apps.cli.bench import main

matplotlib.use("Agg")

RUN = ["run", "--envs", "SineTarget-v0", "--agents", "detections", "--seeds", "2", "--workers", "1"]


def test_runs_with_other_steps_or_episodes_are_separate_rows(tmp_path, capsys):
    """Regression: records of 10- and 20-step runs in one out dir were pooled into one row (n=4)."""
    out = str(tmp_path)
    assert main([*RUN, "--steps", "10", "--out", out]) == 0
    assert main([*RUN, "--steps", "20", "--out", out]) == 0
    assert main([*RUN, "--steps", "20", "--episodes", "2", "--out", out]) == 0
    capsys.readouterr()
    rows = aggregate(load_records(out))
    assert sorted((r.params, r.n) for r in rows) == [
        ((("steps", 10),), 2),
        ((("steps", 20),), 2),
        ((("steps", 20), ("episodes", 2)), 2),
    ]
    assert main(["tables", out]) == 0
    table = capsys.readouterr().out
    for label in ("steps=10", "steps=20", "steps=20, episodes=2"):
        assert label in table
    assert "  4  " not in table  # no pooled row


def test_agent_kwargs_are_separate_rows_in_one_setting():
    records = [
        run_cell(Cell("SineTarget-v0", "gnn", "kf-cv", seed, steps=15, agent_kwargs=kw))
        for seed in (0, 1)
        for kw in ((), (("p_gate", 0.9),))
    ]
    rows = aggregate(records)
    assert sorted((r.params, r.n) for r in rows) == [
        ((("steps", 15),), 2),
        ((("steps", 15), ("agent.p_gate", 0.9)), 2),
    ]
    assert rows[0].setting == rows[1].setting  # the same contest: best marked across both


def test_tables_names_every_skipped_file_and_why(tmp_path, capsys):
    """Regression: a corrupt record was left out of the report without a word."""
    record = run_cell(Cell("SineTarget-v0", "detections", "-", 0, steps=5))
    write_record(tmp_path, record)
    (tmp_path / "truncated.json").write_text('{"schema": 1, "key": "ab')
    (tmp_path / "foreign.json").write_text('{"name": "not a record"}')
    (tmp_path / "future.json").write_text(json.dumps({**record, "schema": 99}))
    (tmp_path / "edited.json").write_text(json.dumps({**record, "key": "0" * 16}))
    assert main(["tables", str(tmp_path)]) == 0
    captured = capsys.readouterr()
    warnings = [line for line in captured.err.splitlines() if "warning: skipped" in line]
    assert len(warnings) == 4
    reasons = {
        "truncated.json": "not valid JSON",
        "foreign.json": "not a track bench record",
        "future.json": "record schema 99, this version reads schema 1",
        "edited.json": "does not match its cell",
    }
    for name, reason in reasons.items():
        assert any(name in w and reason in w for w in warnings), (name, warnings)
    assert "1 records, 4 files skipped" in captured.out
    scan = scan_records(tmp_path)
    assert len(scan.records) == 1 and len(scan.skipped) == 4
    with pytest.warns(SkippedRecordWarning) as caught:
        assert len(load_records(tmp_path)) == 1
    assert len(caught) == 4 and any("truncated.json: not valid JSON" in str(w.message) for w in caught)


def rows_with(metric: str, means: list[float], stds: list[float], sweep: str | None = None) -> list[Row]:
    """Rows of one env, one per (mean, std), as one agent over a sweep or as several agents."""
    return [
        Row(
            "BeltSorter-v0",
            ((sweep, float(i)),) if sweep else (),
            "gnn" if sweep else f"agent{i}",
            "-",
            2,
            {metric: m, "mota": 0.5},
            {metric: s, "mota": 0.1},
        )
        for i, (m, s) in enumerate(zip(means, stds, strict=True))
    ]


def test_counts_spanning_decades_get_a_log_axis():
    assert axis_scale("id_switches", [1.5, 4672.0]) == "log"
    assert axis_scale("id_switches", [0.0, 1.5, 3.0]) == "linear"  # zeros do not count
    assert axis_scale("mota", [0.001, 0.9]) == "linear"  # may be negative: never log
    fig = bar_figure(rows_with("id_switches", [1.5, 4672.0], [0.7, 900.0]))
    scales = {ax.get_title(): ax.get_yscale() for ax in fig.axes}
    assert scales == {"mota": "linear", "id_switches (log)": "log"}
    fig = sweep_figure(
        rows_with("id_switches", [1.5, 40.0, 4672.0], [1.0, 5.0, 10.0], "noise_std"), "noise_std"
    )
    assert {ax.get_title(): ax.get_yscale() for ax in fig.axes}["id_switches (log)"] == "log"


def test_std_bands_of_non_negative_metrics_stay_above_zero():
    lo, hi = error_band("gospa", [0.1, 2.0], [0.5, 0.5])
    np.testing.assert_array_equal(lo, [0.0, 1.5])
    np.testing.assert_array_equal(hi, [0.6, 2.5])
    lo, _ = error_band("mota", [0.1], [0.5])  # MOTA can be negative: not clipped
    np.testing.assert_allclose(lo, [-0.4])
    lo, _ = error_band("id_switches", [1.5, 4672.0], [3.0, 10.0], "log")
    assert np.all(lo > 0) and lo[0] < 1.5  # on a log axis: clipped to a positive floor

    rows = rows_with("gospa", [0.1, 0.2, 0.3], [0.5, 0.5, 0.5], "noise_std")
    (gospa_ax,) = [ax for ax in sweep_figure(rows, "noise_std").axes if ax.get_title() == "gospa"]
    band = gospa_ax.collections[0].get_paths()[0].vertices
    assert band[:, 1].min() == 0.0 and band[:, 1].max() == pytest.approx(0.8)
    (gospa_ax,) = [
        ax for ax in bar_figure(rows_with("gospa", [0.1, 0.3], [0.5, 0.1])).axes if ax.get_title() == "gospa"
    ]
    (bars,) = [c for c in gospa_ax.containers if isinstance(c, ErrorbarContainer)]
    segments = np.concatenate([seg for col in bars.lines[2] for seg in col.get_segments()])
    assert segments[:, 1].min() == 0.0


def test_bench_modules_import_public_names_without_a_circle():
    """Regression: figures and report imported each other, and a claims module the private _save."""
    import ast
    from pathlib import Path

    import track_apps.bench

    root = Path(track_apps.bench.__file__).parent
    graph: dict[str, set[str]] = {}
    for path in root.rglob("*.py"):
        module = "agents." + ".".join(path.relative_to(root.parent).with_suffix("").parts)
        module = module.removesuffix(".__init__")
        graph[module] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("track_apps.bench."):
                graph[module].add(node.module)
                private = [a.name for a in node.names if a.name.startswith("_")]
                assert not private, f"{module} imports private {private} from {node.module}"

    def reaches(start: str, target: str, seen: set[str]) -> bool:
        for nxt in graph.get(start, ()):
            if nxt == target or (nxt not in seen and reaches(nxt, target, seen | {nxt})):
                return True
        return False

    circles = sorted(m for m in graph if reaches(m, m, {m}))
    assert circles == []
