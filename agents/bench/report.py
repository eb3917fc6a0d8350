"""Tables and plots from stored records: terminal, markdown, CSV and PNG (matplotlib Agg).

Rows are (env, env kwargs, agent, predictor) with mean ± std over the seeds (sample std, 0 for a
single seed; NaN values, e.g. an occlusion error without occlusion, are left out). The terminal
and markdown tables show the headline metrics of each env family (:data:`HEADLINE`); the CSV
files hold every metric. Within each env and env-kwargs setting the best value of each
headline metric is marked ``*`` (and bold on a terminal / in markdown), using :data:`LOWER_IS_BETTER`
and :data:`HIGHER_IS_BETTER`.

Files written into the out dir by :func:`write_report`:
    ``results.md``: the headline tables; ``summary.csv``: long form, one row per
    (group, metric) with mean, std, n; ``records.csv``: one row per cell, every metric;
    ``plots/<env>_bars.png``: metric per agent/predictor (error bars: std over seeds);
    ``plots/<env>_<param>_sweep.png``: metric versus a swept env kwarg, one curve per
    agent/predictor with a ±std band (the form of paper 000 Fig. 7 and paper 001 Fig. 7).
"""

from __future__ import annotations

import csv
import math
import os
import sys
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: Metrics shown in the tables and plots, in this order, where an env reports them.
HEADLINE = ("e_mean", "mota", "idf1", "id_switches", "gospa", "mean_error", "rmse", "lost", "oks_mean")
LOWER_IS_BETTER = frozenset(
    {"e1", "e2", "e_mean", "id_switches", "gospa", "mean_error", "rmse", "lost", "motp", "num_misses"}
    | {"num_false_positives", "num_fragmentations", "occlusion_error", "frames_without_estimate"}
)
HIGHER_IS_BETTER = frozenset({"mota", "idf1", "idp", "idr", "oks_mean", "oks_recall", "oks_precision"})


@dataclass(frozen=True)
class Row:
    """Aggregate of the records of one (env, env kwargs, agent, predictor)."""

    env_id: str
    params: tuple[tuple[str, Any], ...]
    agent: str
    predictor: str
    n: int
    mean: dict[str, float]
    std: dict[str, float]

    @property
    def params_label(self) -> str:
        return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.params) or "-"


def _stats(values: Sequence[float]) -> tuple[float, float]:
    finite = [v for v in values if not math.isnan(v)]
    if not finite:
        return math.nan, math.nan
    return float(np.mean(finite)), float(np.std(finite, ddof=1)) if len(finite) > 1 else 0.0


def aggregate(records: Sequence[dict[str, Any]]) -> list[Row]:
    """Rows of mean ± std over seeds, sorted by env, params, agent, predictor."""
    groups: dict[tuple[Any, ...], list[dict[str, float]]] = defaultdict(list)
    for rec in records:
        cell = rec["cell"]
        params = tuple(sorted(cell.get("env_kwargs", {}).items()))
        groups[(cell["env_id"], params, cell["agent"], cell["predictor"])].append(rec["metrics"])
    rows = []
    for (env_id, params, agent, predictor), metrics in groups.items():
        keys = list(dict.fromkeys(k for m in metrics for k in m))
        stats = {k: _stats([float(m.get(k, math.nan)) for m in metrics]) for k in keys}
        mean = {k: s[0] for k, s in stats.items()}
        std = {k: s[1] for k, s in stats.items()}
        rows.append(Row(env_id, params, agent, predictor, len(metrics), mean, std))
    return sorted(rows, key=lambda r: (r.env_id, repr(r.params), r.agent, r.predictor))


def headline(rows: Sequence[Row]) -> list[str]:
    """The headline metrics the rows report."""
    present = {k for r in rows for k in r.mean}
    return [m for m in HEADLINE if m in present]


def best_rows(rows: Sequence[Row], metric: str) -> set[int]:
    """Indices (into ``rows``) of the best value of ``metric`` within each (env, params) setting."""
    if metric not in LOWER_IS_BETTER | HIGHER_IS_BETTER:
        return set()
    sign = -1.0 if metric in HIGHER_IS_BETTER else 1.0
    best: dict[tuple[Any, ...], float] = {}
    for r in rows:
        v = r.mean.get(metric, math.nan)
        if not math.isnan(v):
            key = (r.env_id, r.params)
            best[key] = min(best.get(key, math.inf), sign * v)
    return {
        i
        for i, r in enumerate(rows)
        if not math.isnan(r.mean.get(metric, math.nan))
        and sign * r.mean[metric] == best[(r.env_id, r.params)]
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
    lines.append("\n* best per env and setting (lower is better for errors, higher for MOTA/IDF1/OKS)")
    return "\n".join(lines)


def markdown_table(rows: Sequence[Row]) -> str:
    """The headline tables as markdown; the best value per metric in bold."""
    parts = ["# track-bench results", "", "Mean ± std over seeds; **bold**: best per env and setting."]
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
    with open(out / "summary.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["env_id", "params", "agent", "predictor", "n", "metric", "mean", "std"])
        for r in rows:
            for k in r.mean:
                w.writerow([r.env_id, r.params_label, r.agent, r.predictor, r.n, k, r.mean[k], r.std[k]])
    metric_keys = list(dict.fromkeys(k for rec in records for k in rec["metrics"]))
    fixed = ["env_id", "params", "agent", "predictor", "seed", "episodes", "steps", "wall_s", "frames_per_s"]
    with open(out / "records.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fixed + metric_keys)
        for rec in records:
            c, t = rec["cell"], rec.get("timing", {})
            params = ", ".join(f"{k}={v}" for k, v in sorted(c.get("env_kwargs", {}).items())) or "-"
            head = [c["env_id"], params, c["agent"], c["predictor"], c["seed"], c["episodes"], c["steps"]]
            w.writerow(
                head + [t.get("wall_s"), t.get("frames_per_s")] + [rec["metrics"].get(k) for k in metric_keys]
            )


def _label(r: Row) -> str:
    return r.agent if r.predictor == "-" else f"{r.agent}/{r.predictor}"


def _swept(rows: Sequence[Row]) -> list[str]:
    """Env kwargs with numeric values that differ between the rows (the swept parameters)."""
    values: dict[str, set[Any]] = defaultdict(set)
    for r in rows:
        for k, v in r.params:
            values[k].add(v)
    return [k for k, vs in values.items() if len(vs) > 1 and all(isinstance(v, int | float) for v in vs)]


def plot_env(env_rows: Sequence[Row], out: Path) -> list[Path]:
    """The bar chart of one env and, if it has a sweep, one curve plot per swept parameter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    env_id, metrics = env_rows[0].env_id, headline(env_rows)
    paths: list[Path] = []
    if not metrics:
        return paths
    settings = list(dict.fromkeys(r.params for r in env_rows))
    labels = list(dict.fromkeys(_label(r) for r in env_rows))
    fig, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics) + 1, 3.6), squeeze=False)
    width = 0.8 / len(settings)
    for ax, metric in zip(axes[0], metrics, strict=True):
        for s, params in enumerate(settings):
            sub = {_label(r): r for r in env_rows if r.params == params}
            x = [i + s * width for i, lab in enumerate(labels) if lab in sub]
            y = [sub[lab].mean.get(metric, math.nan) for lab in labels if lab in sub]
            e = [sub[lab].std.get(metric, math.nan) for lab in labels if lab in sub]
            name = next(r.params_label for r in env_rows if r.params == params)
            ax.bar(x, y, width, yerr=e, capsize=2, label=name if len(settings) > 1 else None)
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(labels))], labels, rotation=45, ha="right")
        ax.set_title(metric)
    if len(settings) > 1:
        axes[0][-1].legend(fontsize=6)
    paths.append(_save(fig, out / f"{env_id}_bars.png", f"{env_id}: mean ± std over seeds"))
    for param in _swept(env_rows):
        fig, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics) + 1, 3.4), squeeze=False)
        for ax, metric in zip(axes[0], metrics, strict=True):
            for lab in labels:
                pts = sorted(
                    (dict(r.params)[param], r.mean.get(metric, math.nan), r.std.get(metric, math.nan))
                    for r in env_rows
                    if _label(r) == lab and param in dict(r.params)
                )
                if not pts:
                    continue
                px, pm, ps = (np.array(v, dtype=float) for v in zip(*pts, strict=True))
                ax.plot(px, pm, marker="o", ms=3, label=lab)
                ax.fill_between(px, pm - ps, pm + ps, alpha=0.2)
            ax.set_xlabel(param)
            ax.ticklabel_format(axis="x", style="sci", scilimits=(-2, 3))
            ax.tick_params(axis="x", labelsize=7)
            ax.set_title(metric)
        axes[0][-1].legend(fontsize=6)
        title = f"{env_id}: metric versus {param} (band: ± std over seeds)"
        paths.append(_save(fig, out / f"{env_id}_{param}_sweep.png", title))
    return paths


def _save(fig: Any, path: Path, title: str) -> Path:
    """Title, lay out, write as PNG and close a figure; its path."""
    import matplotlib.pyplot as plt

    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_report(records: Sequence[dict[str, Any]], out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``results.md``, ``summary.csv``, ``records.csv`` and ``plots/*.png``; return their paths."""
    out = Path(out_dir)
    rows = aggregate(records)
    (out / "results.md").write_text(markdown_table(rows))
    write_csvs(records, rows, out)
    paths = [out / "results.md", out / "summary.csv", out / "records.csv"]
    plots = out / "plots"
    plots.mkdir(exist_ok=True)
    for env_id in dict.fromkeys(r.env_id for r in rows):
        paths += plot_env([r for r in rows if r.env_id == env_id], plots)
    return paths
