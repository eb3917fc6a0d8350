"""benchmarks/association_study.py on synthetic records: its intervals and its paired contrasts.

The records are written by the runner's own ``records.csv`` writer, so the params column is
parsed as a run writes it. Every metric of a synthetic cell is

    value = unit effect (large, one per particle kind, merges, noise and seed)
            + contestant effect + (optionally) a small per-cell term,

so a paired contrast removes the unit effect exactly, and its interval is that of the cell terms.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from track_apps.bench.cells import Cell, kwarg_items
from track_apps.bench.tables import write_csvs

_SPEC = importlib.util.spec_from_file_location(
    "association_study", Path(__file__).parents[3] / "benchmarks" / "association_study.py"
)
assert _SPEC is not None and _SPEC.loader is not None
study = importlib.util.module_from_spec(_SPEC)
sys.modules[_SPEC.name] = study  # dataclasses look their module up there
_SPEC.loader.exec_module(study)

KINDS, MERGES, NOISES, SEEDS = ("cylinder", "sphere"), (True, False), (0.0, 5e-4), (0, 1, 2, 3)
#: e_mean of each contestant (agent, merge model, predictor): under gnn the nll-lstm gains 0.02
#: over kf-ca, under jpda 0.05, so the difference of differences (as shipped) is 0.03; jpda's
#: merge model is worth 0.01 with kf-ca and 0.02 with the nll-lstm.
E_MEAN = {
    ("gnn", False, "kf-ca"): 0.10,
    ("gnn", False, "nll-lstm"): 0.08,
    ("jpda", True, "kf-ca"): 0.09,
    ("jpda", True, "nll-lstm"): 0.04,
    ("jpda", False, "kf-ca"): 0.10,
    ("jpda", False, "nll-lstm"): 0.06,
}


def _cell(
    agent: str, merge_model: bool, predictor: str, kind: str, merges: bool, noise: float, seed: int
) -> Cell:
    env = {"max_detections": 512, "merge_touching": merges, "noise_std": noise, "particle_kind": kind}
    kwargs: dict[str, Any] = {"predict_sorting": False}
    if agent == "jpda":
        kwargs["merge_model"] = merge_model
    elif merge_model:
        kwargs["blob_extent"] = 0.004
    return Cell("BeltSorter-v0", agent, predictor, seed, kwarg_items(env), 1, None, kwarg_items(kwargs))


def write_records(
    tmp_path: Path, cell_noise: float = 0.0, contestants: dict = E_MEAN, steps: int | None = None
) -> Path:
    """A records.csv of every contestant × unit; returns its path."""
    rng = np.random.default_rng(7)
    records = []
    for kind in KINDS:
        for merges in MERGES:
            for noise in NOISES:
                for seed in SEEDS:
                    unit = rng.uniform(0.0, 0.5)
                    for (agent, mm, predictor), effect in contestants.items():
                        cell = _cell(agent, mm, predictor, kind, merges, noise, seed)
                        if steps is not None and agent == "jpda":
                            cell = Cell(
                                cell.env_id,
                                agent,
                                predictor,
                                seed,
                                cell.env_kwargs,
                                1,
                                steps,
                                cell.agent_kwargs,
                            )
                        v = unit + effect + cell_noise * rng.standard_normal()
                        metrics = {
                            "e_mean": v,
                            "mota": 1 - v,
                            "idf1": 1 - v,
                            "hota": 1 - 2 * v,
                            "id_switches": 1000 * v,
                        }
                        records.append(
                            {"cell": cell.to_dict(), "metrics": metrics, "timing": {"wall_s": 1.0}}
                        )
    write_csvs(records, [], tmp_path)
    return tmp_path / "records.csv"


def test_t_interval_is_the_student_t_interval_of_the_mean():
    mean, low, high, n = study.t_interval([1.0, 2.0, 3.0, 4.0, 5.0])
    half = 2.7764451051977987 * math.sqrt(2.5) / math.sqrt(5)  # t_{0.975, 4} s / sqrt(n)
    assert (mean, n) == (3.0, 5)
    assert low == pytest.approx(3.0 - half, abs=1e-12) and high == pytest.approx(3.0 + half, abs=1e-12)
    mean, low, high, n = study.t_interval([2.0, math.nan])  # NaN left out: one value, no interval
    assert (mean, n) == (2.0, 1) and math.isnan(low) and math.isnan(high)
    assert study.t_interval([])[3] == 0


def test_stratified_interval_is_the_mean_of_the_level_means_with_welch_satterthwaite_freedom():
    mean, low, high, n = study.stratified_interval([[1.0, 2.0, 3.0], [10.0, 12.0]])
    # level means 2 and 11; v = s²/n = 1/3 and 2/2; ν = (4/3)² / ((1/3)²/2 + 1²/1) = 32/19
    se = math.sqrt(1 / 3 + 1) / 2
    half = float(stats.t.ppf(0.975, 32 / 19)) * se
    assert (mean, n) == (6.5, 5)
    assert low == pytest.approx(6.5 - half, abs=1e-12) and high == pytest.approx(6.5 + half, abs=1e-12)
    # a difference that changes from level to level but not within one has a zero-width interval
    assert study.stratified_interval([[1.0, 1.0], [5.0, 5.0]]) == (3.0, 3.0, 3.0, 4)
    assert math.isnan(study.stratified_interval([[1.0, 2.0], [3.0]])[1])


def test_params_of_records_csv_are_parsed_as_the_runner_writes_them(tmp_path):
    table = study.load_table(write_records(tmp_path))
    assert len(table) == len(E_MEAN) * 2 * 2 * 2 * 4
    assert set(table["particle_kind"]) == set(KINDS) and set(table["noise_std"]) == set(NOISES)
    assert set(table["merge_touching"]) == {True, False}
    got = set(table[["agent", "merge_model", "predictor"]].itertuples(index=False, name=None))
    assert got == set(E_MEAN)


def test_paired_contrasts_remove_the_unit_effect_exactly(tmp_path):
    con = study.contrast_table(study.load_table(write_records(tmp_path)))
    pooled = con[(con["noise_std"] == study.ALL_NOISE) & (con["metric"] == "e_mean")].set_index(
        ["contrast", "particle_kind", "merge_touching"]
    )
    expected = {
        "nll-lstm over kf-ca, gnn": 0.02,
        "nll-lstm over kf-ca, jpda": 0.05,
        "nll-lstm over kf-ca, jpda (no merge model)": 0.04,
        "difference of differences, no merge model": 0.02,
        "difference of differences, as shipped": 0.03,
        "merge model, jpda/kf-ca": 0.01,
        "merge model, jpda/nll-lstm": 0.02,
        "jpda over gnn, kf-ca": 0.01,
        "jpda over gnn, nll-lstm": 0.04,
    }
    for name, value in expected.items():
        rows = pooled.loc[name]
        assert len(rows) == 4 and set(rows["n"]) == {2 * 4}  # 2 noise levels x 4 seeds per stratum
        np.testing.assert_allclose(rows["mean"], value, atol=1e-12)
        np.testing.assert_allclose(rows["high"] - rows["low"], 0.0, atol=1e-12)
        assert set(rows["verdict"]) == {"+"}
    # higher-is-better metrics keep the sign: MOTA = 1 - v gains as much as e_mean
    mota = con[(con["noise_std"] == study.ALL_NOISE) & (con["metric"] == "mota")]
    dod = mota[mota["contrast"] == "difference of differences, as shipped"]
    np.testing.assert_allclose(dod["mean"], 0.03, atol=1e-12)
    # contrasts that need gnn with blob sharing have no records: absent, not NaN rows
    assert (
        not con["contrast"].isin(["difference of differences, merge models", "merge model, gnn/kf-ca"]).any()
    )


def test_the_difference_of_differences_intervals_are_those_of_its_per_unit_values(tmp_path):
    table = study.load_table(write_records(tmp_path, cell_noise=0.01))
    con = study.contrast_table(table)
    row = con[
        (con["contrast"] == "difference of differences, as shipped")
        & (con["metric"] == "e_mean")
        & (con["particle_kind"] == "sphere")
        & (con["merge_touching"] == True)  # noqa: E712
        & (con["noise_std"] == study.ALL_NOISE)
    ].iloc[0]
    sub = table[(table["particle_kind"] == "sphere") & table["merge_touching"]]
    e = sub.set_index(["noise_std", "seed", "agent", "merge_model", "predictor"])["e_mean"]
    per_level = [
        [
            (e[(n, s, "jpda", True, "kf-ca")] - e[(n, s, "jpda", True, "nll-lstm")])
            - (e[(n, s, "gnn", False, "kf-ca")] - e[(n, s, "gnn", False, "nll-lstm")])
            for s in SEEDS
        ]
        for n in NOISES
    ]
    mean, low, high, n = study.stratified_interval(per_level)
    assert (row["mean"], row["low"], row["high"], row["n"]) == pytest.approx((mean, low, high, n), abs=1e-12)
    # and per noise level, the t interval over the seeds
    at_zero = con[
        (con["contrast"] == "difference of differences, as shipped")
        & (con["metric"] == "e_mean")
        & (con["particle_kind"] == "sphere")
        & (con["merge_touching"] == True)  # noqa: E712
        & (con["noise_std"] == 0.0)
    ].iloc[0]
    expected = study.t_interval(per_level[0])
    assert (at_zero["mean"], at_zero["low"], at_zero["high"], at_zero["n"]) == pytest.approx(
        expected, abs=1e-12
    )
    assert low < 0.03 < high  # the true value, with cell terms of std 0.01 against a unit effect of up to 0.5
    # unpaired, the unit effect would swamp it: the spread of one contestant's values over the units
    assert sub.groupby(["agent", "merge_model", "predictor"])["e_mean"].std().min() > 0.05


def test_without_jpda_records_the_gnn_contrasts_and_their_tables_are_written(tmp_path):
    gnn_only = {k: v for k, v in E_MEAN.items() if k[0] == "gnn"}
    table = study.load_table(write_records(tmp_path, contestants=gnn_only))
    paths = study.write_study(table, tmp_path / "out", figures=False)
    assert [p.name for p in paths] == ["means.csv", "contrasts.csv", "means.md", "contrasts.md"]
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    con = pd.read_csv(tmp_path / "out" / "contrasts.csv")
    assert set(con["contrast"]) == {"nll-lstm over kf-ca, gnn"}
    assert "No jpda records" in (tmp_path / "out" / "contrasts.md").read_text()


def test_records_of_several_episode_lengths_are_refused(tmp_path):
    with pytest.raises(ValueError, match="episode lengths"):
        study.load_table(write_records(tmp_path, steps=300))


@pytest.mark.parametrize(
    ("metric", "a", "b", "expected"),
    [("e_mean", 0.1, 0.3, 0.2), ("id_switches", 5.0, 2.0, -3.0), ("idf1", 0.9, 0.8, 0.1)],
)
def test_better_is_positive_when_the_first_did_better(metric, a, b, expected):
    got = study.better(metric, pd.Series([a]), pd.Series([b]))
    assert got.iloc[0] == pytest.approx(expected)


def test_verdict_and_merge_model_of():
    assert [study.verdict(*x) for x in [(0.1, 0.2), (-0.2, -0.1), (-0.1, 0.1), (math.nan, math.nan)]] == [
        "+",
        "−",
        "no difference",
        "",
    ]
    assert study.merge_model_of("jpda", {}) and not study.merge_model_of("jpda", {"agent.merge_model": False})
    assert study.merge_model_of("gnn", {"agent.blob_extent": 0.004}) and not study.merge_model_of("gnn", {})
    assert study.parse_params(
        "merge_touching=False, noise_std=0.0005, particle_kind=sphere, agent.samples=250"
    ) == {
        "merge_touching": False,
        "noise_std": 5e-4,
        "particle_kind": "sphere",
        "agent.samples": 250,
    }


@pytest.mark.slow
@pytest.mark.parametrize("gnn_only", [False, True])
def test_every_figure_is_written_with_and_without_jpda_records(tmp_path, gnn_only):
    contestants = {k: v for k, v in E_MEAN.items() if k[0] == "gnn" or not gnn_only}
    paths = study.write_study(
        study.load_table(write_records(tmp_path, contestants=contestants)), tmp_path / "out"
    )
    pngs = [p.name for p in paths if p.suffix == ".png"]
    assert pngs == ["means.png", "gain.png", "dod.png", "merge_model.png"]
    assert all(p.stat().st_size > 1000 for p in paths if p.suffix == ".png")
