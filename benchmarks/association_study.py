"""The association study (docs/association.md) from the records of ``track bench run --suite association``.

Reads the run's ``records.csv`` (one row per cell, written by ``track bench run`` and ``track bench
tables``) and writes into ``--out`` (default ``docs/figures/association``):

- ``means.csv`` / ``means.md``: every contestant's mean of each metric per setting with its 95 %
  confidence interval over the seeds;
- ``contrasts.csv`` / ``contrasts.md``: the paired contrasts below, per setting and pooled over
  the noise levels, with 95 % confidence intervals;
- ``means.png``, ``gain.png``, ``dod.png``, ``merge_model.png``: the figures.

**Units and pairing.** Every cell of one unit ``u = (particle_kind, merge_touching, noise_std,
seed)`` sees the same stream (the env is seeded by the cell's seed alone), so contrasts are
differences taken within a unit and then averaged. A **contestant** is (association, merge
model, predictor): the association is the agent (``gnn``, ``jpda``); the merge model is on for
``jpda`` unless ``merge_model = false`` and for ``gnn`` when ``blob_extent > 0``.

**Improvement.** For a metric ``m``, ``better_m(a, b) = m(a) − m(b)`` when higher is better
(MOTA, IDF1, HOTA) and ``m(b) − m(a)`` when lower is better (e_mean, ID switches), so a positive
number always means that ``a`` did better than ``b``.

**Contrasts** (per unit ``u``, then averaged):

- gain of nll-lstm over kf-ca under association ``A`` with merge model ``M``:
  ``g_u(A, M) = better_m(A/M/nll-lstm, A/M/kf-ca)``;
- difference of differences, jpda against gnn:
  ``Δ_u = g_u(jpda, M_j) − g_u(gnn, M_g)``, positive when the nll-lstm gains more under jpda;
  with each association as it ships (jpda with its merge model, gnn without) and with the
  merge model matched (both off, both on);
- the merge model's worth for association ``A`` and predictor ``P``:
  ``w_u = better_m(A/on/P, A/off/P)``;
- jpda over gnn for predictor ``P``, each as it ships: ``better_m(jpda/on/P, gnn/off/P)``.

**Confidence intervals.** For paired differences ``d_1 … d_n`` (or a contestant's values over
its seeds), the mean ``d̄`` and the Student-t interval

.. math::

    \\bar d \\pm t_{0.975,\\,n-1} \\, s / \\sqrt{n}, \\qquad s^2 = \\frac{1}{n-1} \\sum_k (d_k - \\bar d)^2,

per setting (``n`` = seeds). Pooled over the noise levels of a (particle kind, merges) stratum,
the interval is one of the mean over those levels of their means (`stratified_interval`:
the standard error from the spread within each level, Welch–Satterthwaite degrees of freedom),
since the levels are fixed design points. ``n = 1`` gives no interval (NaN). An interval that
covers 0 is reported as "no difference". The intervals are not corrected for the number of
contrasts.

Usage::

    python benchmarks/association_study.py results/association --out docs/figures/association
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from track_envs.infra.atomic import write_text
from track_envs.io import save_figure

#: The metrics of the study, in table order.
METRICS = ("e_mean", "mota", "idf1", "hota", "id_switches")
#: Metrics where a smaller value is better (the others: larger is better).
LOWER_IS_BETTER = frozenset({"e_mean", "id_switches"})
#: What one unit of pairing is: every contestant sees the same stream within a unit.
UNIT = ("particle_kind", "merge_touching", "noise_std", "seed")
#: A stratum: the pooled intervals pool its noise levels and seeds.
STRATUM = ("particle_kind", "merge_touching")
#: A setting: a stratum at one noise level (its intervals are over the seeds).
SETTING = ("particle_kind", "merge_touching", "noise_std")
#: Columns that name a contestant.
CONTESTANT = ("agent", "merge_model", "predictor")
#: Confidence level of every interval.
LEVEL = 0.95
#: The two predictors of the main contrast: the calibrated nll-lstm against kf-ca.
LEARNED, BASELINE = "nll-lstm", "kf-ca"
#: The predictors of the merge-model arm of the suite.
ARM_PREDICTORS = (BASELINE, LEARNED)
#: The pooled rows of a contrast have this in their noise column.
ALL_NOISE = "all"

_PARAM_SPLIT = re.compile(r", (?=[\w.]+=)")


def parse_value(text: str) -> Any:
    """A value of the ``params`` column of ``records.csv``: bool, int, float or the string."""
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_params(text: str) -> dict[str, Any]:
    """``"merge_touching=True, noise_std=0.0005, agent.samples=250"`` → a dict (``"-"``: empty)."""
    if not text or text == "-":
        return {}
    out = {}
    for item in _PARAM_SPLIT.split(text):
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"params item {item!r} of {text!r} is not NAME=VALUE")
        out[name] = parse_value(value)
    return out


def merge_model_of(agent: str, params: dict[str, Any]) -> bool:
    """Whether the cell's tracker ran with a merge model: jpda unless ``merge_model = false``,
    gnn with ``blob_extent > 0``; any other agent has none."""
    if agent == "jpda":
        return bool(params.get("agent.merge_model", True))
    if agent == "gnn":
        return float(params.get("agent.blob_extent", 0.0)) > 0.0
    return False


def load_table(path: str | Path) -> pd.DataFrame:
    """The BeltSorter-v0 rows of a ``records.csv``: one row per cell with the columns of
    `UNIT`, `CONTESTANT`, ``steps``, ``wall_s`` and `METRICS`.

    Raises:
        ValueError: when a metric column is missing, when the records mix episode lengths
            (``steps``) or when a contestant has two records in one unit.
    """
    raw = pd.read_csv(path)
    missing = [m for m in METRICS if m not in raw.columns]
    if missing:
        raise ValueError(f"{path}: no column {missing}; columns are {list(raw.columns)}")
    raw = raw[raw["env_id"] == "BeltSorter-v0"]
    rows = []
    for rec in raw.to_dict("records"):
        params = parse_params(str(rec["params"]))
        rows.append(
            {
                "particle_kind": params.get("particle_kind", "cylinder"),
                "merge_touching": bool(params.get("merge_touching", True)),
                "noise_std": float(params.get("noise_std", 1e-4)),
                "seed": int(rec["seed"]),
                "agent": rec["agent"],
                "merge_model": merge_model_of(rec["agent"], params),
                "predictor": rec["predictor"],
                "steps": params.get("steps", 1500),
                "wall_s": float(rec.get("wall_s", math.nan)),
                **{m: float(rec[m]) for m in METRICS},
            }
        )
    table = pd.DataFrame(rows, columns=[*UNIT, *CONTESTANT, "steps", "wall_s", *METRICS])
    if table["steps"].nunique() > 1:
        raise ValueError(f"{path}: records of several episode lengths {sorted(table['steps'].unique())}")
    dup = table.duplicated([*UNIT, *CONTESTANT], keep=False)
    if dup.any():
        raise ValueError(f"{path}: several records of one contestant and unit:\n{table[dup]}")
    return table


def t_interval(values: Sequence[float] | np.ndarray, level: float = LEVEL) -> tuple[float, float, float, int]:
    """``(mean, low, high, n)``: the Student-t interval ``mean ± t_{(1+level)/2, n−1} s / √n`` of
    the finite ``values`` (low = high = NaN for fewer than 2, all NaN for none)."""
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    n = len(x)
    if n == 0:
        return math.nan, math.nan, math.nan, 0
    mean = float(x.mean())
    if n < 2:
        return mean, math.nan, math.nan, 1
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return mean, mean - half, mean + half, n


def stratified_interval(
    groups: Sequence[Sequence[float] | np.ndarray], level: float = LEVEL
) -> tuple[float, float, float, int]:
    """``(mean, low, high, n)`` of the mean over ``groups`` (the noise levels) of each group's mean.

    With ``L`` groups of ``n_l`` finite values, means ``x̄_l`` and variances ``s_l²``:
    ``x̄ = (1/L) Σ x̄_l``, ``SE² = (1/L²) Σ v_l`` with ``v_l = s_l² / n_l``, and the interval
    ``x̄ ± t_{(1+level)/2, ν} SE`` with Welch–Satterthwaite's ``ν = (Σ v_l)² / Σ v_l² / (n_l − 1)``.
    The levels are fixed design points, so how much the difference changes from one level to
    the next is no part of the error (pooling the values into one t interval would count it).
    ``n`` is the number of values; low = high = NaN when a group has fewer than 2, all NaN when
    there is none.
    """
    xs = [np.asarray(g, dtype=np.float64) for g in groups]
    xs = [x[np.isfinite(x)] for x in xs]
    xs = [x for x in xs if len(x)]
    n = sum(len(x) for x in xs)
    if not xs:
        return math.nan, math.nan, math.nan, 0
    mean = float(np.mean([x.mean() for x in xs]))
    if min(len(x) for x in xs) < 2:
        return mean, math.nan, math.nan, n
    v = np.array([x.var(ddof=1) / len(x) for x in xs])
    if v.sum() == 0.0:
        return mean, mean, mean, n
    dof = v.sum() ** 2 / np.sum(v**2 / np.array([len(x) - 1 for x in xs]))
    half = float(stats.t.ppf(0.5 + level / 2, dof) * math.sqrt(v.sum()) / len(xs))
    return mean, mean - half, mean + half, n


def better(metric: str, a: pd.Series, b: pd.Series) -> pd.Series:
    """How much better ``a`` did than ``b`` on ``metric`` (positive: ``a`` better)."""
    return b - a if metric in LOWER_IS_BETTER else a - b


def wide(table: pd.DataFrame, metric: str) -> pd.DataFrame:
    """``metric`` with one row per unit and one column per contestant (NaN where it did not run)."""
    return table.pivot_table(index=list(UNIT), columns=list(CONTESTANT), values=metric, aggfunc="first")


Contestant = tuple[str, bool, str]


def column(w: pd.DataFrame, contestant: Contestant) -> pd.Series:
    """A contestant's column of `wide` (all NaN when it has no record)."""
    return w[contestant] if contestant in w.columns else pd.Series(np.nan, index=w.index)


def gain(w: pd.DataFrame, metric: str, agent: str, merge_model: bool) -> pd.Series:
    """Per unit: how much better the nll-lstm did than kf-ca under ``agent`` with ``merge_model``."""
    return better(metric, column(w, (agent, merge_model, LEARNED)), column(w, (agent, merge_model, BASELINE)))


@dataclass(frozen=True)
class Contrast:
    """A paired contrast: its name, what a positive value means, and its per-unit differences."""

    name: str
    positive: str
    diff: Callable[[pd.DataFrame, str], pd.Series]


def contrasts() -> list[Contrast]:
    """Every contrast of the study (see the module docstring), in report order."""
    out = [
        Contrast(
            f"{LEARNED} over {BASELINE}, gnn",
            f"{LEARNED} better under gnn (no merge model)",
            lambda w, m: gain(w, m, "gnn", False),
        ),
        Contrast(
            f"{LEARNED} over {BASELINE}, jpda",
            f"{LEARNED} better under jpda (merge model)",
            lambda w, m: gain(w, m, "jpda", True),
        ),
        Contrast(
            f"{LEARNED} over {BASELINE}, jpda (no merge model)",
            f"{LEARNED} better under jpda without its merge model",
            lambda w, m: gain(w, m, "jpda", False),
        ),
        Contrast(
            f"{LEARNED} over {BASELINE}, gnn (blobs)",
            f"{LEARNED} better under gnn with blob sharing",
            lambda w, m: gain(w, m, "gnn", True),
        ),
        Contrast(
            "difference of differences, as shipped",
            f"{LEARNED} gains more under jpda (merge model) than under gnn (none)",
            lambda w, m: gain(w, m, "jpda", True) - gain(w, m, "gnn", False),
        ),
        Contrast(
            "difference of differences, no merge model",
            f"{LEARNED} gains more under jpda than under gnn, both without a merge model",
            lambda w, m: gain(w, m, "jpda", False) - gain(w, m, "gnn", False),
        ),
        Contrast(
            "difference of differences, merge models",
            f"{LEARNED} gains more under jpda than under gnn, both with their merge model",
            lambda w, m: gain(w, m, "jpda", True) - gain(w, m, "gnn", True),
        ),
    ]
    for agent in ("jpda", "gnn"):
        for predictor in ARM_PREDICTORS:
            out.append(
                Contrast(
                    f"merge model, {agent}/{predictor}",
                    f"the merge model helps {agent}/{predictor}",
                    lambda w, m, a=agent, p=predictor: better(
                        m, column(w, (a, True, p)), column(w, (a, False, p))
                    ),
                )
            )
    return out


def jpda_over_gnn(predictor: str) -> Contrast:
    """jpda (merge model) against gnn (none) with one predictor, each as it ships."""
    return Contrast(
        f"jpda over gnn, {predictor}",
        f"jpda better with {predictor}",
        lambda w, m: better(m, column(w, ("jpda", True, predictor)), column(w, ("gnn", False, predictor))),
    )


def verdict(low: float, high: float) -> str:
    """``"+"`` (interval above 0), ``"−"`` (below), ``"no difference"`` (covers 0), ``""`` (none)."""
    if math.isnan(low) or math.isnan(high):
        return ""
    if low > 0:
        return "+"
    if high < 0:
        return "−"
    return "no difference"


def summarize(diff: pd.Series) -> list[dict[str, Any]]:
    """Intervals of per-unit differences: per setting (`t_interval` over the seeds), and per
    stratum over its noise levels (`stratified_interval`, noise column `ALL_NOISE`)."""
    rows: list[dict[str, Any]] = []
    d = diff.dropna()
    if d.empty:
        return rows
    frame = d.rename("d").reset_index()
    for (kind, merges), part in frame.groupby(list(STRATUM), sort=True):
        levels = [(noise, sub["d"].to_numpy()) for noise, sub in part.groupby("noise_std", sort=True)]
        intervals = [(noise, t_interval(values)) for noise, values in levels]
        intervals.append((ALL_NOISE, stratified_interval([values for _, values in levels])))
        for noise, (mean, low, high, n) in intervals:
            rows.append(
                {
                    "particle_kind": kind,
                    "merge_touching": merges,
                    "noise_std": noise,
                    "mean": mean,
                    "low": low,
                    "high": high,
                    "n": n,
                    "verdict": verdict(low, high),
                }
            )
    return rows


def contrast_table(table: pd.DataFrame) -> pd.DataFrame:
    """Every contrast (`contrasts`, then jpda over gnn per predictor) × metric, with its
    intervals per setting and pooled (`summarize`); contrasts without records are absent."""
    predictors = list(dict.fromkeys(table["predictor"]))
    rows = []
    for metric in METRICS:
        w = wide(table, metric)
        for c in [*contrasts(), *(jpda_over_gnn(p) for p in predictors)]:
            for row in summarize(c.diff(w, metric)):
                rows.append({"contrast": c.name, "positive": c.positive, "metric": metric, **row})
    columns = ["contrast", "positive", "metric", *SETTING, "mean", "low", "high", "n", "verdict"]
    return pd.DataFrame(rows, columns=columns)


def means_table(table: pd.DataFrame) -> pd.DataFrame:
    """Each contestant's mean and 95 % interval over its seeds, per setting and metric."""
    rows = []
    for keys, part in table.groupby([*SETTING, *CONTESTANT], sort=True):
        base = dict(zip([*SETTING, *CONTESTANT], keys, strict=True))
        for metric in METRICS:
            mean, low, high, n = t_interval(part[metric].to_numpy())
            rows.append({**base, "metric": metric, "mean": mean, "low": low, "high": high, "n": n})
    return pd.DataFrame(rows, columns=[*SETTING, *CONTESTANT, "metric", "mean", "low", "high", "n"])


# ---- text


def contestant_label(agent: Any, merge_model: Any, predictor: Any) -> str:
    """``"jpda/nll-lstm"``, ``"jpda (no merge model)/kf-ca"``, ``"gnn (blobs)/kf-ca"``."""
    agent, merge_model = str(agent), bool(merge_model)
    if agent == "jpda" and not merge_model:
        agent = "jpda (no merge model)"
    elif agent == "gnn" and merge_model:
        agent = "gnn (blobs)"
    return f"{agent}/{predictor}"


def stratum_label(kind: Any, merges: Any) -> str:
    """``"cylinder, merges"`` / ``"sphere, no merges"``."""
    return f"{kind}, {'merges' if merges else 'no merges'}"


def noise_label(noise: Any) -> str:
    """``"0.2 mm"``, or ``"all"`` for pooled rows."""
    return noise if isinstance(noise, str) else f"{float(noise) * 1e3:g} mm"


def fmt(mean: float, low: float, high: float, metric: str) -> str:
    """``"0.1234 [0.1100, 0.1368]"`` (ID switches with one decimal)."""
    mean, low, high = float(mean), float(low), float(high)
    if math.isnan(mean):
        return "–"
    spec = ".1f" if metric == "id_switches" else ".4f"
    if math.isnan(low):
        return f"{mean:{spec}}"
    return f"{mean:{spec}} [{low:{spec}}, {high:{spec}}]"


def cell_text(by_metric: pd.DataFrame, metric: str) -> str:
    """`fmt` of the row ``metric`` of a table indexed by metric."""
    row = by_metric.loc[metric]
    return fmt(float(row["mean"]), float(row["low"]), float(row["high"]), metric)


def markdown(header: Sequence[str], body: Sequence[Sequence[str]]) -> list[str]:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in body]


def means_markdown(means: pd.DataFrame) -> str:
    """One table per stratum: contestant × noise rows, a metric per column."""
    parts = [
        "# Association study: means with 95 % confidence intervals over the seeds",
        "",
        "Generated by `benchmarks/association_study.py`; every value: mean [95 % CI].",
    ]
    for (kind, merges), part in means.groupby(list(STRATUM), sort=True):
        parts += ["", f"## {stratum_label(kind, merges)}", ""]
        body = []
        for keys, sub in part.groupby(["noise_std", *CONTESTANT], sort=True):
            noise, agent, merge_model, predictor = keys
            by_metric = sub.set_index("metric")
            body.append(
                [noise_label(noise), contestant_label(agent, merge_model, predictor), str(sub["n"].max())]
                + [cell_text(by_metric, m) for m in METRICS]
            )
        parts += markdown(["noise", "contestant", "seeds", *METRICS], body)
    return "\n".join(parts) + "\n"


def contrasts_markdown(con: pd.DataFrame, table: pd.DataFrame) -> str:
    """The contrasts pooled over the noise (one table each), then the difference of differences
    per noise level."""
    n_cells, cpu_min = len(table), table["wall_s"].sum() / 60
    parts = [
        "# Association study: paired contrasts with 95 % confidence intervals",
        "",
        f"Generated by `benchmarks/association_study.py` from {n_cells} records "
        f"({cpu_min:.1f} min of cell time). Every value: mean [95 % CI] of the per-unit difference "
        "(unit: particle kind, merges, noise, seed); positive means the first named did better "
        '(for e_mean and ID switches: fewer). "no difference": the interval covers 0.',
    ]
    if not (table["agent"] == "jpda").any():
        parts += ["", "No jpda records: the contrasts that need jpda are absent."]
    pooled = con[con["noise_std"] == ALL_NOISE]
    for name, part in pooled.groupby("contrast", sort=False):
        parts += [
            "",
            f"## {name}",
            "",
            f"Positive: {part['positive'].iloc[0]}. Pooled over the noise levels.",
            "",
        ]
        body = []
        for (kind, merges), sub in part.groupby(list(STRATUM), sort=True):
            by_metric = sub.set_index("metric")
            body.append(
                [stratum_label(kind, merges), str(by_metric["n"].max())]
                + [
                    f"{cell_text(by_metric, m)} {by_metric.loc[m, 'verdict']}"
                    if m in by_metric.index
                    else "–"
                    for m in METRICS
                ]
            )
        parts += markdown(["stratum", "n", *METRICS], body)
    dod = con[con["contrast"].str.startswith("difference of differences") & (con["noise_std"] != ALL_NOISE)]
    if not dod.empty:
        parts += ["", "## Difference of differences per noise level", ""]
        body = []
        for keys, sub in dod.groupby(["contrast", *SETTING], sort=False):
            name, kind, merges, noise = keys
            by_metric = sub.set_index("metric")
            body.append(
                [
                    name.removeprefix("difference of differences, "),
                    stratum_label(kind, merges),
                    noise_label(noise),
                ]
                + [cell_text(by_metric, m) for m in METRICS]
            )
        parts += markdown(["variant", "stratum", "noise", *METRICS], body)
    return "\n".join(parts) + "\n"


# ---- figures

#: Line style per (association, merge model).
STYLES = {("gnn", False): "-", ("jpda", True): "--", ("gnn", True): ":", ("jpda", False): "-."}
METRIC_LABELS = {
    "e_mean": "e_mean",
    "mota": "MOTA",
    "idf1": "IDF1",
    "hota": "HOTA",
    "id_switches": "ID switches",
}


def _strata(table: pd.DataFrame) -> list[tuple[str, bool]]:
    return sorted({(k, bool(m)) for k, m in table[list(STRATUM)].itertuples(index=False)})


def _errorbar(ax: Any, x: np.ndarray, part: pd.DataFrame, **kwargs: Any) -> None:
    mean, low, high = (part[c].to_numpy(dtype=np.float64) for c in ("mean", "low", "high"))
    err = np.vstack([mean - low, high - mean])
    ax.errorbar(x, mean, yerr=np.nan_to_num(err), capsize=2, **kwargs)


def means_figure(means: pd.DataFrame) -> Any:
    """Each metric (rows) per stratum (columns) over the noise: one line per contestant, 95 % CI bars."""
    import matplotlib.pyplot as plt

    strata = _strata(means)
    fig, axes = plt.subplots(
        len(METRICS),
        len(strata),
        figsize=(3.6 * len(strata), 2.4 * len(METRICS)),
        squeeze=False,
        layout="constrained",
    )
    predictors = list(dict.fromkeys(means["predictor"]))
    colors = {p: f"C{i}" for i, p in enumerate(predictors)}
    for j, (kind, merges) in enumerate(strata):
        sub = means[(means["particle_kind"] == kind) & (means["merge_touching"] == merges)]
        for i, metric in enumerate(METRICS):
            ax = axes[i, j]
            for (agent, mm, predictor), part in sub[sub["metric"] == metric].groupby(list(CONTESTANT)):
                part = part.sort_values("noise_std")
                _errorbar(
                    ax,
                    part["noise_std"].to_numpy() * 1e3,
                    part,
                    color=colors[predictor],
                    linestyle=STYLES.get((agent, bool(mm)), "-"),
                    marker="o",
                    markersize=3,
                    label=contestant_label(agent, bool(mm), predictor),
                )
            ax.set_title(stratum_label(kind, merges), fontsize=9)
            ax.set_ylabel(METRIC_LABELS[metric])
            if i == len(METRICS) - 1:
                ax.set_xlabel("noise std (mm)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(5, max(1, len(labels))), fontsize=7)
    return fig


def gain_figure(con: pd.DataFrame) -> Any:
    """The nll-lstm's gain over kf-ca over the noise, per association (lines), metric (rows) and
    stratum (columns), with 95 % CI bars; positive: the nll-lstm did better."""
    import matplotlib.pyplot as plt

    gains = con[
        con["contrast"].str.startswith(f"{LEARNED} over {BASELINE}") & (con["noise_std"] != ALL_NOISE)
    ]
    strata = _strata(gains) if not gains.empty else []
    fig, axes = plt.subplots(
        len(METRICS),
        max(1, len(strata)),
        figsize=(3.6 * max(1, len(strata)), 2.4 * len(METRICS)),
        squeeze=False,
        layout="constrained",
    )
    for j, (kind, merges) in enumerate(strata):
        sub = gains[(gains["particle_kind"] == kind) & (gains["merge_touching"] == merges)]
        for i, metric in enumerate(METRICS):
            ax = axes[i, j]
            ax.axhline(0.0, color="0.6", linewidth=0.8)
            for k, (name, part) in enumerate(sub[sub["metric"] == metric].groupby("contrast", sort=False)):
                part = part.sort_values("noise_std")
                x = part["noise_std"].to_numpy(dtype=np.float64) * 1e3 + 0.008 * (k - 1.5)
                label = str(name).removeprefix(f"{LEARNED} over {BASELINE}, ")
                label += {"gnn": " (no merge model)", "jpda": " (merge model)"}.get(label, "")
                _errorbar(ax, x, part, marker="o", markersize=3, label=label)
            ax.set_title(stratum_label(kind, merges), fontsize=9)
            ax.set_ylabel(f"Δ {METRIC_LABELS[metric]}")
            if i == len(METRICS) - 1:
                ax.set_xlabel("noise std (mm)")
    fig.suptitle(f"gain of {LEARNED} over {BASELINE} (positive: {LEARNED} better), 95 % CI", fontsize=10)
    if strata:
        axes[0, 0].legend(fontsize=7)
    return fig


def forest_figure(con: pd.DataFrame, names: Sequence[str], title: str) -> Any:
    """Pooled intervals of the contrasts ``names`` (rows: contrast × stratum), one panel per metric."""
    import matplotlib.pyplot as plt

    pooled = con[con["contrast"].isin(names) & (con["noise_std"] == ALL_NOISE)]
    labels = [
        (name, kind, merges) for name in names for kind, merges in _strata(pooled[pooled["contrast"] == name])
    ]
    fig, axes = plt.subplots(
        1,
        len(METRICS),
        figsize=(3.2 * len(METRICS), 1.2 + 0.3 * max(1, len(labels))),
        squeeze=False,
        layout="constrained",
    )
    if not labels:
        fig.text(0.5, 0.4, "no records of these contrasts", ha="center", fontsize=10)
    for i, metric in enumerate(METRICS):
        ax = axes[0, i]
        ax.axvline(0.0, color="0.6", linewidth=0.8)
        sub = pooled[pooled["metric"] == metric].set_index(["contrast", "particle_kind", "merge_touching"])
        for y, key in enumerate(labels):
            if key not in sub.index:
                continue
            r = sub.loc[key]
            lo, hi = r["low"], r["high"]
            color = f"C{names.index(key[0])}"
            ax.plot([lo, hi], [y, y], color=color, linewidth=1.5)
            ax.plot([r["mean"]], [y], "o", color=color, markersize=4)
        ax.set_yticks(range(len(labels)))
        ax.set_yticklabels(
            [f"{n.split(', ', 1)[-1]} | {stratum_label(k, m)}" for n, k, m in labels] if i == 0 else [],
            fontsize=7,
        )
        ax.invert_yaxis()
        ax.set_title(f"Δ {METRIC_LABELS[metric]}", fontsize=9)
    fig.suptitle(title, fontsize=10)
    return fig


def save(fig: Any, path: Path) -> Path:
    """Write a figure as PNG (100 dpi) and close it."""
    import matplotlib.pyplot as plt

    try:
        save_figure(fig, path, dpi=100, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def write_study(table: pd.DataFrame, out: str | Path, *, figures: bool = True) -> list[Path]:
    """Write the tables (and, with ``figures``, the figures) of the study into ``out``; their paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    means, con = means_table(table), contrast_table(table)
    paths = [out / "means.csv", out / "contrasts.csv", out / "means.md", out / "contrasts.md"]
    write_text(paths[0], means.to_csv(index=False))
    write_text(paths[1], con.to_csv(index=False))
    write_text(paths[2], means_markdown(means))
    write_text(paths[3], contrasts_markdown(con, table))
    if not figures:
        return paths
    import matplotlib

    matplotlib.use("Agg")
    paths.append(save(means_figure(means), out / "means.png"))
    paths.append(save(gain_figure(con), out / "gain.png"))
    dods = [c.name for c in contrasts() if c.name.startswith("difference of differences")]
    paths.append(
        save(
            forest_figure(
                con, dods, f"(gain of {LEARNED} over {BASELINE}) jpda − gnn, pooled over the noise, 95 % CI"
            ),
            out / "dod.png",
        )
    )
    merges = [c.name for c in contrasts() if c.name.startswith("merge model")]
    paths.append(
        save(
            forest_figure(con, merges, "merge model on − off, pooled over the noise, 95 % CI"),
            out / "merge_model.png",
        )
    )
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "results", help="out dir of 'track bench run --suite association', or its records.csv"
    )
    parser.add_argument("--out", default="docs/figures/association", help="folder of the tables and figures")
    args = parser.parse_args(argv)
    path = Path(args.results)
    if path.is_dir():
        path = path / "records.csv"
    if not path.is_file():
        print(f"error: no {path} (track bench tables DIR writes it)", file=sys.stderr)
        return 2
    table = load_table(path)
    paths = write_study(table, args.out)
    print((Path(args.out) / "contrasts.md").read_text())
    print(f"{len(table)} records; wrote {len(paths)} files into {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
