"""The pollithy2020 suite: its structure, one tiny cell of each figure kind, the claims command."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import pytest

from track_apps.bench import expand
from track_apps.bench.cells import Cell, load_suite, override, packaged_suites, suite_names
from track_apps.bench.runner import load_records, run_cell, write_record
from track_apps.bench.tables import aggregate, write_tables
from track_apps.cli.bench import main

matplotlib.use("Agg")
NOISE = {0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4}


def test_every_toml_in_the_suite_folder_is_a_named_suite():
    shipped = packaged_suites()
    folder = Path(__file__).parents[3] / "track_apps" / "bench" / "suites"
    assert set(shipped) == {p.stem for p in folder.glob("*.toml")}
    assert "pollithy2020" in shipped and "pollithy2020" in suite_names()
    assert load_suite("pollithy2020") == load_suite(str(shipped["pollithy2020"]))
    with pytest.raises(ValueError, match="pollithy2020"):
        load_suite("no-such-suite")
    # every suite has a quick variant, the main ones too (they are TOML files like the others)
    assert {"quick", "full", "sorting"} <= set(shipped)
    assert load_suite("full", quick=True) != load_suite("full")


def test_full_suite_has_every_figure_of_the_paper():
    cells = expand(load_suite("pollithy2020"))
    fig7 = [c for c in cells if c.agent == "gnn" and "merge_touching" not in dict(c.env_kwargs)]
    assert {c.predictor for c in fig7} == {"kf-cv", "kf-ca", "lstm", "nll-lstm", "mc-lstm"}
    assert {dict(c.env_kwargs)["noise_std"] for c in fig7} == NOISE
    assert {c.seed for c in fig7} == set(range(10)) and {c.steps for c in fig7} == {None}
    assert {dict(c.agent_kwargs).get("samples") for c in fig7 if c.predictor == "mc-lstm"} == {250}
    one_step = [c for c in cells if c.agent == "one-step"]
    assert all(dict(c.env_kwargs)["merge_touching"] is False for c in one_step)
    mc = {dict(c.agent_kwargs)["samples"] for c in one_step if c.predictor == "mc-lstm"}
    assert mc == {10, 100, 250, 1000}
    kinds = {dict(c.env_kwargs).get("particle_kind") for c in one_step}
    assert {"cylinder", "sphere", "cuboid"} <= kinds
    table1 = {dict(c.env_kwargs).get("noise_std") for c in one_step if c.predictor == "nll-lstm"}
    assert table1 == NOISE


def test_quick_variant_is_small_and_keeps_every_figure_kind():
    cells = expand(load_suite("pollithy2020", quick=True))
    assert len(cells) <= 25 and {c.steps for c in cells} == {200} and {c.seed for c in cells} == {0}
    assert {c.agent for c in cells} == {"one-step", "gnn"}
    assert {c.predictor for c in cells if c.agent == "gnn"} == {
        "kf-cv",
        "kf-ca",
        "lstm",
        "nll-lstm",
        "mc-lstm",
    }


@pytest.fixture(scope="module")
def tiny_records(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One short cell of each figure kind, run and written as records."""
    groups = override(load_suite("pollithy2020", quick=True), steps=20)
    cells = expand(groups)

    def pick(agent: str, predictor: str, noise: float | None = None, samples: int | None = None) -> Cell:
        for c in cells:
            env, kw = dict(c.env_kwargs), dict(c.agent_kwargs)
            same = c.agent == agent and c.predictor == predictor and kw.get("samples") == samples
            if same and (noise is None or env.get("noise_std") == noise):
                return c
        raise AssertionError(f"no cell {agent}/{predictor}")

    chosen = [
        pick("one-step", "nll-lstm", 1e-4),  # Fig. 6 box, Figs. 3-4, Fig. 8
        pick("one-step", "nll-lstm", 5e-4),  # Table I
        pick("one-step", "mc-lstm", samples=10),  # Fig. 6, reliability of a dropout model
        pick("gnn", "kf-cv", 0.0),  # Fig. 7
        pick("gnn", "kf-cv", 5e-4),
    ]
    out = tmp_path_factory.mktemp("pollithy2020")
    for cell in chosen:
        write_record(out, run_cell(cell))
    return out


def _png(path: Path) -> None:
    assert path.is_file() and path.stat().st_size > 5_000, path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_draws_the_new_plot_kinds(tiny_records: Path, tmp_path: Path):
    paths = write_tables(load_records(tiny_records), tmp_path)
    names = {p.name for p in paths}
    assert any(n.startswith("BeltSorter-v0_track_error_box") for n in names)
    assert {"BeltSorter-v0_reliability.png", "BeltSorter-v0_aleatoric_age.png"} <= names
    for p in paths:
        if p.suffix == ".png":
            _png(p)


def test_claims_table_is_regenerated_from_the_records(tiny_records: Path, tmp_path: Path):
    assert main(["claims", "pollithy2020", str(tiny_records), "--out", str(tmp_path), "--wall-s", "60"]) == 0
    md = (tmp_path / "pollithy2020.md").read_text()
    assert "| 1 |" in md and "Table I" in md and "wall time of the run: 1.0 min" in md
    assert "**holds**" in md or "**partly**" in md or "**does not hold**" in md
    figures = tmp_path / "figures" / "pollithy2020"
    for name in ("fig6_track_error_cylinder", "fig7_e_mean", "fig3_4_reliability", "fig8_aleatoric_age"):
        _png(figures / f"{name}.png")
    assert main(["claims", "pollithy2020", str(tiny_records), "--out", str(tmp_path), "--wall-s", "60"]) == 0
    assert (tmp_path / "pollithy2020.md").read_text() == md  # a pure function of the records


def test_claims_command_refuses_unknown_suites_and_empty_dirs(tmp_path: Path, capsys):
    assert main(["claims", "no-such-paper", str(tmp_path)]) == 2
    assert "pollithy2020" in capsys.readouterr().err
    assert main(["claims", "pollithy2020", str(tmp_path)]) == 2
    assert "no records" in capsys.readouterr().err


def test_rows_of_tiny_records_have_the_figure_keys(tiny_records: Path):
    rows = aggregate(load_records(tiny_records))
    one_step = [r for r in rows if r.agent == "one-step"]
    assert all("track_error_p50" in r.mean and "reliability_raw@0.20" in r.mean for r in one_step)
    assert all("e_mean" in r.mean for r in rows if r.agent == "gnn")


@pytest.mark.slow
def test_quick_variant_runs_through_the_cli(tmp_path: Path):
    out = tmp_path / "quick"
    assert main(["run", "--suite", "pollithy2020", "--quick", "--workers", "2", "--out", str(out)]) == 0
    assert len(load_records(out)) == len(expand(load_suite("pollithy2020", quick=True)))
    assert main(["claims", "pollithy2020", str(out), "--out", str(tmp_path / "docs")]) == 0
