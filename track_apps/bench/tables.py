"""Tables and plots from stored records: terminal, markdown, CSV and PNG (matplotlib Agg).

Rows ([`track_apps.bench.rows`][track_apps.bench.rows]) are (env, params, agent, predictor) with mean ± std
over the seeds; records made with other steps, episodes or kwargs in the same out dir are separate rows.
The terminal and markdown tables show the headline metrics of each env family
([`HEADLINE`][track_apps.bench.tables.HEADLINE]); the CSV files hold every metric. Within each env and setting
(the params but the agent kwargs) the best value of each headline metric is marked ``*`` (and bold on a
terminal / in markdown), using [`LOWER_IS_BETTER`][track_apps.bench.tables.LOWER_IS_BETTER] and
[`HIGHER_IS_BETTER`][track_apps.bench.tables.HIGHER_IS_BETTER].

Plot axes ([`axis_scale`][track_apps.bench.tables.axis_scale],
[`error_band`][track_apps.bench.tables.error_band]): a metric that cannot be negative
([`NON_NEGATIVE`][track_apps.bench.tables.NON_NEGATIVE]) gets a log y axis when its positive values span more
than [`LOG_SPAN`][track_apps.bench.tables.LOG_SPAN] (two decades, e.g. 1.5 and 4,672 id switches), and its
±std bars and bands are clipped at 0 (on a log axis, at the bottom of the axis).

Files written into the out dir by [`write_tables`][track_apps.bench.write_tables]:
    ``results.md``: the headline tables; ``summary.csv``: long form, one row per
    (group, metric) with mean, std, n; ``records.csv``: one row per cell, every metric;
    ``plots/<env>_bars.png``: metric per agent/predictor (error bars: std over seeds);
    ``plots/<env>_<param>_sweep.png``: metric versus a swept env kwarg, one curve per
    agent/predictor with a ±std band (the form of Pollithy et al. 2020, Fig. 7, and Jung et al. 2019, Fig. 7);
    ``plots/<env>_sorting_errors.png`` (envs with ``sorting_*`` metrics): the distribution of the
    temporal and lateral errors of the predicted nozzle-bar crossings, as their percentiles
    (50, 90, 95, 99) per agent/predictor and setting, at the default noise when it was swept;
    for records of predictor scores (agent ``one-step``,
    [`track_apps.bench.figures`][track_apps.bench.figures]):
    ``plots/<env>_track_error_box*.png`` (box plots of the per-track prediction error),
    ``plots/<env>_reliability.png`` (reliability diagrams before and after calibration) and
    ``plots/<env>_aleatoric_age.png`` (covariance area over the track's age, with Pearson's r).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from track_apps.bench.cells import Cell
from track_apps.bench.figures import predictor_figures
from track_apps.bench.ranking import agent_is_ranked
from track_apps.bench.rows import Row, aggregate, params_text, row_label, save_figure
from track_envs.infra.atomic import atomic_write, write_text

# Row, aggregate and params_text live in track_apps.bench.rows and are importable from here as before.

#: Metrics shown in the tables and plots, in this order, where an env reports them.
HEADLINE = (
    *("e_mean", "e1", "e2", "mota", "idf1", "hota", "det_a", "ass_a", "id_switches", "gospa"),
    *("mean_error", "rmse", "lost", "oks_mean"),
    *("sorting_hit_rate", "sorting_time_p95_ms", "sorting_lateral_p95_mm"),
)
#: The error keys of the sorting prediction (track_envs.metrics.sorting), lower is better.
SORTING_ERRORS = frozenset(
    f"sorting_{axis}_{stat}_{unit}"
    for axis, unit in (("time", "ms"), ("lateral", "mm"))
    for stat in ("rmse", "p50", "p90", "p95", "p99")
)
LOWER_IS_BETTER = frozenset(
    {"e1", "e2", "e_mean", "id_switches", "gospa", "mean_error", "rmse", "lost", "motp", "num_misses"}
    | {"num_false_positives", "num_fragmentations", "occlusion_error", "frames_without_estimate"}
    | SORTING_ERRORS
)
HIGHER_IS_BETTER = frozenset(
    {"mota", "idf1", "idp", "idr", "oks_mean", "oks_recall", "oks_precision", "sorting_hit_rate"}
    | {"sorting_predicted", "hota", "det_a", "ass_a", "loc_a", "det_re", "det_pr", "ass_re", "ass_pr"}
)
#: Metrics that cannot be negative (every scored metric but MOTA, which is 1 - errors / truths).
NON_NEGATIVE = (LOWER_IS_BETTER | HIGHER_IS_BETTER | {"e1", "e2", "num_switches"}) - {"mota"}
#: Ratio of the largest to the smallest positive value beyond which a y axis is logarithmic.
LOG_SPAN = 100.0


def headline(rows: Sequence[Row]) -> list[str]:
    """The headline metrics the rows report."""
    present = {k for r in rows for k in r.mean}
    return [m for m in HEADLINE if m in present]


def best_rows(rows: Sequence[Row], metric: str) -> set[int]:
    """Indices (into ``rows``) of the best value of ``metric`` within each (env, setting), among
    the trackers only
    ([`track_apps.bench.ranking.agent_is_ranked`][track_apps.bench.ranking.agent_is_ranked]): the no-tracking
    ``detections`` reference (e1 = 0, so e_mean = 0, by construction) and truth-reading oracles are never
    best."""
    if metric not in LOWER_IS_BETTER | HIGHER_IS_BETTER:
        return set()
    sign = -1.0 if metric in HIGHER_IS_BETTER else 1.0
    ranked = {name: agent_is_ranked(name) for name in {r.agent for r in rows}}
    rows = [r if ranked[r.agent] else dataclasses.replace(r, mean={}) for r in rows]
    best: dict[tuple[Any, ...], float] = {}
    for r in rows:
        v = r.mean.get(metric, math.nan)
        if not math.isnan(v):
            key = (r.env_id, r.setting)
            best[key] = min(best.get(key, math.inf), sign * v)
    return {
        i
        for i, r in enumerate(rows)
        if not math.isnan(r.mean.get(metric, math.nan))
        and sign * r.mean[metric] == best[(r.env_id, r.setting)]
    }


def _cell_text(row: Row, metric: str) -> str:
    m, s = row.mean.get(metric, math.nan), row.std.get(metric, math.nan)
    return "nan" if math.isnan(m) else f"{m:.4g} ± {s:.2g}"


def _env_tables(rows: Sequence[Row]) -> list[tuple[str, list[str], list[list[str]], list[set[int]]]]:
    """Per env: title, header, body cells, and for each metric column the best row indices."""
    out = []
    for env_id in dict.fromkeys(r.env_id for r in rows):
        env_rows = [r for r in rows if r.env_id == env_id]
        metrics = headline(env_rows)
        header = ["params", "agent", "predictor", "n", *metrics]
        body = [
            [r.params_label, r.agent, r.predictor, str(r.n)] + [_cell_text(r, m) for m in metrics]
            for r in env_rows
        ]
        out.append((env_id, header, body, [best_rows(env_rows, m) for m in metrics]))
    return out


def terminal_table(rows: Sequence[Row], color: bool | None = None) -> str:
    """Plain-text tables, one per env; the best value per metric marked ``*`` (bold on a tty)."""
    if color is None:
        color = sys.stdout.isatty() and "NO_COLOR" not in os.environ
    lines = []
    for env_id, header, body, best in _env_tables(rows):
        for j, winners in enumerate(best):
            for i in winners:
                body[i][4 + j] += "*"
        widths = [max(len(h), *(len(b[c]) for b in body)) for c, h in enumerate(header)]
        lines.append(f"\n{env_id}")
        lines.append("  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)).rstrip())
        lines.append("  ".join("-" * w for w in widths))
        for b in body:
            cells = [v.ljust(w) for v, w in zip(b, widths, strict=True)]
            if color:
                cells = [
                    f"\033[1m{c}\033[0m" if v.endswith("*") else c for c, v in zip(cells, b, strict=True)
                ]
            lines.append("  ".join(cells).rstrip())
    lines.append(
        "\n* best tracker per env and setting (lower is better for errors, higher for MOTA/IDF1/HOTA/OKS);"
        " references (detections, one-step) are not ranked"
    )
    return "\n".join(lines)


def markdown_table(rows: Sequence[Row]) -> str:
    """The headline tables as markdown; the best value per metric in bold."""
    parts = [
        "# track bench results",
        "",
        "Mean ± std over seeds; **bold**: best tracker per env and setting (the references, detections"
        " and one-step, are not ranked).",
    ]
    for env_id, header, body, best in _env_tables(rows):
        for j, winners in enumerate(best):
            for i in winners:
                body[i][4 + j] = f"**{body[i][4 + j]}**"
        parts += ["", f"## {env_id}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        parts += ["| " + " | ".join(b) + " |" for b in body]
    parts += ["", "Every metric: `summary.csv` (aggregates) and `records.csv` (one row per cell).", ""]
    return "\n".join(parts)


def write_csvs(records: Sequence[dict[str, Any]], rows: Sequence[Row], out: Path) -> None:
    """``summary.csv`` (long form aggregates) and ``records.csv`` (one row per cell)."""
    with atomic_write(out / "summary.csv", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["env_id", "params", "agent", "predictor", "n", "metric", "mean", "std"])
        for r in rows:
            for k in r.mean:
                w.writerow([r.env_id, r.params_label, r.agent, r.predictor, r.n, k, r.mean[k], r.std[k]])
    metric_keys = list(dict.fromkeys(k for rec in records for k in rec["metrics"]))
    fixed = ["env_id", "params", "agent", "predictor", "seed", "episodes", "steps", "wall_s", "frames_per_s"]
    with atomic_write(out / "records.csv", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fixed + metric_keys)
        for rec in records:
            c, t = Cell.from_dict(rec["cell"]), rec.get("timing", {})
            head = [c.env_id, params_text(c.params()), c.agent, c.predictor, c.seed, c.episodes, c.steps]
            w.writerow(
                head + [t.get("wall_s"), t.get("frames_per_s")] + [rec["metrics"].get(k) for k in metric_keys]
            )


def _swept(rows: Sequence[Row]) -> list[str]:
    """Setting params with numeric values that differ between the rows (the swept parameters)."""
    values: dict[str, set[Any]] = defaultdict(set)
    for r in rows:
        for k, v in r.setting:
            values[k].add(v)
    return [
        k
        for k, vs in values.items()
        if len(vs) > 1 and all(isinstance(v, int | float) and not isinstance(v, bool) for v in vs)
    ]


def axis_scale(metric: str, values: ArrayLike) -> str:
    """``"log"`` for a [`NON_NEGATIVE`][track_apps.bench.tables.NON_NEGATIVE] metric whose positive finite
    ``values`` span more than [`LOG_SPAN`][track_apps.bench.tables.LOG_SPAN] (max / min), else ``"linear"``.

    Counts such as id switches differ by decades between trackers (1.5 and 4,672 on one belt);
    on a linear axis the small ones read as 0.
    """
    if metric not in NON_NEGATIVE:
        return "linear"
    arr = np.asarray(values, dtype=float)
    positive = arr[np.isfinite(arr) & (arr > 0)]
    if positive.size < 2:
        return "linear"
    return "log" if positive.max() / positive.min() > LOG_SPAN else "linear"


def error_band(
    metric: str, mean: ArrayLike, std: ArrayLike, scale: str = "linear"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper ends of a mean ± std bar or band.

    For a [`NON_NEGATIVE`][track_apps.bench.tables.NON_NEGATIVE] metric the lower end is clipped at 0 (a count
    or an error cannot be negative); on a log axis, where 0 has no place, at half the smallest positive
    mean or upper end instead. NaN std (no finite value) gives NaN ends.
    """
    m, sd = np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
    lo, hi = m - sd, m + sd
    if metric in NON_NEGATIVE:
        lo = np.maximum(lo, 0.0)
        if scale == "log":
            candidates = np.concatenate([m, hi])
            positive = candidates[np.isfinite(candidates) & (candidates > 0)]
            floor = 0.5 * positive.min() if positive.size else 1.0
            lo = np.where(lo > 0, lo, np.minimum(floor, np.where(m > 0, m, floor)))
    return lo, hi


def bar_figure(env_rows: Sequence[Row]) -> Any:
    """The bar chart of one env: one panel per headline metric, one bar per contestant and
    setting, error bars ± std over seeds (clipped, see [`error_band`][track_apps.bench.tables.error_band])."""
    import matplotlib.pyplot as plt

    metrics = headline(env_rows)
    settings = list(dict.fromkeys(r.setting for r in env_rows))
    labels = list(dict.fromkeys(row_label(r) for r in env_rows))
    fig, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics) + 1, 3.6), squeeze=False)
    width = 0.8 / len(settings)
    for ax, metric in zip(axes[0], metrics, strict=True):
        scale = axis_scale(metric, [r.mean.get(metric, math.nan) for r in env_rows])
        ax.set_yscale(scale)
        for s, setting in enumerate(settings):
            sub = {row_label(r): r for r in env_rows if r.setting == setting}
            x = [i + s * width for i, lab in enumerate(labels) if lab in sub]
            y = np.array([sub[lab].mean.get(metric, math.nan) for lab in labels if lab in sub])
            e = np.array([sub[lab].std.get(metric, math.nan) for lab in labels if lab in sub])
            lo, hi = error_band(metric, y, e, scale)
            yerr = np.vstack([np.maximum(y - lo, 0.0), hi - y])
            name = params_text(setting) if len(settings) > 1 else None
            ax.bar(x, y, width, yerr=yerr, capsize=2, label=name)
            if scale == "log":  # a zero has no bar on a log axis: say so
                for xi in np.asarray(x)[y == 0]:
                    ax.text(xi, 0.01, "0", transform=ax.get_xaxis_transform(), ha="center", fontsize=7)
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(labels))], labels, rotation=45, ha="right")
        ax.set_title(metric + (" (log)" if scale == "log" else ""))
    if len(settings) > 1:
        axes[0][-1].legend(fontsize=6)
    fig.suptitle(f"{env_rows[0].env_id}: mean ± std over seeds")
    return fig


def sweep_figure(env_rows: Sequence[Row], param: str) -> Any:
    """Metric versus ``param``: one curve per contestant (and per value of the other params,
    when they vary), with a ± std band (clipped, see [`error_band`][track_apps.bench.tables.error_band])."""
    import matplotlib.pyplot as plt

    metrics = headline(env_rows)
    curves: dict[tuple[str, tuple[Any, ...]], list[Row]] = defaultdict(list)
    for r in env_rows:
        if param in dict(r.setting):
            others = tuple((k, v) for k, v in r.setting if k != param)
            curves[(row_label(r), others)].append(r)
    several = len({others for _, others in curves}) > 1
    fig, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics) + 1, 3.4), squeeze=False)
    for ax, metric in zip(axes[0], metrics, strict=True):
        scale = axis_scale(metric, [r.mean.get(metric, math.nan) for r in env_rows])
        ax.set_yscale(scale)
        for (lab, others), rows in curves.items():
            pts = sorted(
                (dict(r.setting)[param], r.mean.get(metric, math.nan), r.std.get(metric, math.nan))
                for r in rows
            )
            px, pm, ps = (np.array(v, dtype=float) for v in zip(*pts, strict=True))
            lo, hi = error_band(metric, pm, ps, scale)
            name = f"{lab}, {params_text(others)}" if several else lab
            ax.plot(px, pm, marker="o", ms=3, label=name)
            ax.fill_between(px, lo, hi, alpha=0.2)
        ax.set_xlabel(param)
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-2, 3))
        ax.tick_params(axis="x", labelsize=7)
        ax.set_title(metric + (" (log)" if scale == "log" else ""))
    axes[0][-1].legend(fontsize=6)
    fig.suptitle(f"{env_rows[0].env_id}: metric versus {param} (band: ± std over seeds)")
    return fig


def plot_env(env_rows: Sequence[Row], out: Path) -> list[Path]:
    """The bar chart of one env and, if it has a sweep, one curve plot per swept parameter."""
    import matplotlib

    matplotlib.use("Agg")

    env_id = env_rows[0].env_id
    if not headline(env_rows):
        return []
    paths = [save_figure(bar_figure(env_rows), out / f"{env_id}_bars.png")]
    for param in _swept(env_rows):
        paths.append(save_figure(sweep_figure(env_rows, param), out / f"{env_id}_{param}_sweep.png"))
    sorting = sorting_error_figure(env_rows)
    if sorting is not None:
        paths.append(save_figure(sorting, out / f"{env_id}_sorting_errors.png"))
    return paths + predictor_figures(env_rows, out)


#: Percentile keys of the sorting errors (track_envs.metrics.sorting.PERCENTILES).
SORTING_PERCENTILES = (50, 90, 95, 99)
#: The default hit tolerances of the sorting score (SortingPrediction): ±2 ms, ±1.5 mm.
SORTING_TOLERANCES = {"time": 2.0, "lateral": 1.5}


def sorting_error_figure(env_rows: Sequence[Row]) -> Any | None:
    """Percentiles of ``|Δt|`` (ms) and ``|Δy|`` (mm) of the predicted crossings, one curve per
    contestant and setting; where ``noise_std`` was swept, the rows at the value nearest 1e-4."""
    import matplotlib.pyplot as plt

    rows = [r for r in env_rows if "sorting_time_p50_ms" in r.mean]
    if not rows:
        return None
    noise = sorted({float(v) for r in rows if (v := dict(r.setting).get("noise_std")) is not None})
    if len(noise) > 1:
        chosen = min(noise, key=lambda v: abs(v - 1e-4))
        rows = [r for r in rows if dict(r.setting).get("noise_std") == chosen]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), squeeze=False)
    for ax, (axis, unit) in zip(axes[0], (("time", "ms"), ("lateral", "mm")), strict=True):
        for r in rows:
            values = [r.mean.get(f"sorting_{axis}_p{q}_{unit}", math.nan) for q in SORTING_PERCENTILES]
            others = params_text(r.setting)
            ax.plot(SORTING_PERCENTILES, values, marker="o", ms=3, label=f"{row_label(r)}, {others}")
        tolerance = SORTING_TOLERANCES[axis]
        ax.axhline(tolerance, color="k", lw=0.8, ls="--")
        ax.text(50, tolerance, f" valve tolerance {tolerance:g} {unit}", fontsize=7, va="bottom")
        ax.set_yscale("log")
        ax.set_xlabel("percentile")
        ax.set_ylabel(f"|error| ({unit})")
        ax.set_title(f"{axis} error of the predicted crossing")
    axes[0][1].legend(fontsize=5)
    fig.suptitle(f"{env_rows[0].env_id}: sorting error distribution (mean over seeds)")
    return fig


def write_tables(records: Sequence[dict[str, Any]], out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``results.md``, ``summary.csv``, ``records.csv`` and ``plots/*.png``; return their paths."""
    out = Path(out_dir)
    rows = aggregate(records)
    write_text(out / "results.md", markdown_table(rows))
    write_csvs(records, rows, out)
    paths = [out / "results.md", out / "summary.csv", out / "records.csv"]
    plots = out / "plots"
    plots.mkdir(exist_ok=True)
    for env_id in dict.fromkeys(r.env_id for r in rows):
        paths += plot_env([r for r in rows if r.env_id == env_id], plots)
    return paths
