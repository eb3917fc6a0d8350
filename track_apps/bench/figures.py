"""Plot kinds of ``track bench tables`` for predictor scores: box plots, reliability diagrams and
the area-over-age scatter with Pearson's r.

They read the aggregated [`Row`][track_apps.bench.rows.Row] s (means over seeds) of the keys that
[`agents.one_step.OneStepAgent`][agents.one_step.OneStepAgent] records:

* **box plot** ([`box_figure`][track_apps.bench.figures.box_figure]): the per-track mean absolute prediction
error
  (``track_error_p05`` … ``p95``, [`track_envs.metrics.track_error`][track_envs.metrics.track_error]), box
  25–75 %, median, whiskers 5 % and 95 %, one box per contestant; each quantile is the mean of the seeds'
  quantiles (the seeds are episodes of equal length, so this is close to the pooled quantile).
* **reliability diagram** ([`reliability_figure`][track_apps.bench.figures.reliability_figure]): the empirical
against the expected
  confidence level (``reliability@p``, and ``reliability_raw@p`` before calibration), with the
  cumulative histogram of the predictions' levels as light bars (Pollithy et al. 2020, Figs. 3–4).
* **scatter with r** ([`age_scatter_figure`][track_apps.bench.figures.age_scatter_figure]): the mean
bounding-box area ``4 σ_x σ_y`` per
  number of observations of the track, ± its std, marker area ∝ the number of predictions, and
  Pearson's r over all predictions (Pollithy et al. 2020, Fig. 8;
  [`track_envs.metrics.aleatoric`][track_envs.metrics.aleatoric]).

Units: the belt's sensor unit is the metre; errors are drawn in mm and areas in mm² there
(``unit_scale``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from track_apps.bench.rows import Row, params_text, row_label, save_figure
from track_envs.metrics.aleatoric import MAX_AGE, area_key, pooled_r
from track_envs.metrics.track_error import BOX_QUANTILES, quantile_key

_LEVEL = re.compile(r"^reliability@([0-9.]+)$")
_LEVEL_RAW = re.compile(r"^reliability_raw@([0-9.]+)$")


def unit_scale(env_id: str) -> tuple[float, str]:
    """Factor from sensor units to the plotted unit and its name: metres → mm on the belt envs."""
    return (1e3, "mm") if env_id.startswith("Belt") else (1.0, "sensor units")


def box_stats(row: Row, scale: float = 1.0) -> dict[str, Any] | None:
    """``matplotlib.axes.Axes.bxp`` statistics of a row's per-track errors (None without them)."""
    q = [row.mean.get(quantile_key(p), math.nan) * scale for p in BOX_QUANTILES]
    if any(math.isnan(v) for v in q):
        return None
    return {
        "whislo": q[0],
        "q1": q[1],
        "med": q[2],
        "q3": q[3],
        "whishi": q[4],
        "mean": row.mean.get("track_error_mean", math.nan) * scale,
        "fliers": [],
    }


def box_figure(entries: Sequence[tuple[str, Row]], title: str, unit: str = "mm", scale: float = 1e3) -> Any:
    """Box plot of the per-track mean absolute prediction error, one box per ``(label, row)``."""
    import matplotlib.pyplot as plt

    stats, labels = [], []
    for label, row in entries:
        s = box_stats(row, scale)
        if s is not None:
            stats.append(s | {"label": label})
            labels.append(label)
    fig, ax = plt.subplots(figsize=(1.0 * max(len(stats), 4) + 2, 4.2))
    if stats:
        ax.bxp(stats, showmeans=True, meanprops={"marker": "^", "markersize": 4})
        values = [s[k] for s in stats for k in ("whislo", "whishi") if s[k] > 0]
        if values and max(values) / min(values) > 30:
            ax.set_yscale("log")
    ax.set_ylabel(f"per-track mean absolute prediction error ({unit})")
    ax.set_title(title, fontsize=9)
    ax.tick_params(axis="x", rotation=40, labelsize=7)
    plt.setp(ax.get_xticklabels(), horizontalalignment="right")
    ax.grid(axis="y", alpha=0.3)
    ax.text(
        0.99,
        0.98,
        "box 25–75 %, line median, ▲ mean, whiskers 5 % / 95 %",
        transform=ax.transAxes,
        ha="right",
        va="top",
        fontsize=7,
    )
    return fig


def reliability_points(row: Row, raw: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Expected (k,) and empirical (k,) levels of a row's reliability curve, sorted
    (``raw``: before calibration)."""
    pattern = _LEVEL_RAW if raw else _LEVEL
    pts = sorted((float(m.group(1)), v) for k, v in row.mean.items() if (m := pattern.match(k)))
    if not pts:
        return np.zeros(0), np.zeros(0)
    expected, empirical = (np.array(v, dtype=float) for v in zip(*pts, strict=True))
    return expected, empirical


def reliability_figure(panels: Sequence[tuple[str, Row, bool]], title: str = "") -> Any:
    """Reliability diagrams, one panel per ``(title, row, raw)``: the curve over the diagonal and
    the cumulative histogram of the predictions' confidence levels (bars on the 0.05 grid)."""
    import matplotlib.pyplot as plt

    n = max(len(panels), 1)
    cols = min(n, 2)
    rows_ = math.ceil(n / cols)
    fig, axes = plt.subplots(rows_, cols, figsize=(4.3 * cols, 4.2 * rows_), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, (name, row, raw) in zip(axes.flat, panels, strict=False):
        expected, empirical = reliability_points(row, raw)
        grid = np.isclose(expected * 20, np.round(expected * 20))
        edges = expected[grid]
        ax.bar(
            edges,
            empirical[grid],
            width=-0.05,
            align="edge",
            color="lightblue",
            edgecolor="white",
            label="cumulative histogram",
        )
        ax.plot([0, 1], [0, 1], color="0.4", ls="--", lw=1, label="calibrated")
        ax.plot(expected, empirical, marker="o", ms=3, color="C0", label="reliability curve")
        at = {round(float(e), 3): float(v) for e, v in zip(expected, empirical, strict=True)}
        note = ", ".join(f"p={p:g}: {at[p]:.3f}" for p in (0.2, 0.5, 0.999) if p in at)
        ax.text(0.97, 0.33, note, transform=ax.transAxes, fontsize=7, ha="right", va="bottom")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1.02)
        ax.set_xlabel("expected confidence level p")
        ax.set_ylabel("empirical confidence level")
        ax.set_title(name, fontsize=9)
        ax.legend(loc="lower right", fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def age_series(row: Row, scale: float = 1.0) -> dict[str, Any]:
    """Per-age count, mean and std of the area (scaled by ``scale``, e.g. m² → mm²: 1e6) and the
    pooled Pearson r of a row (ages with no prediction left out of the arrays)."""
    ages = np.arange(1, MAX_AGE + 1)
    count = np.array([row.mean.get(area_key("count", a), math.nan) for a in range(1, MAX_AGE + 1)])
    mean = np.array([row.mean.get(area_key("area", a), math.nan) for a in range(1, MAX_AGE + 1)])
    sq = np.array([row.mean.get(area_key("area_sq", a), math.nan) for a in range(1, MAX_AGE + 1)])
    ok = np.isfinite(count) & (count > 0) & np.isfinite(mean)
    r = pooled_r(np.where(ok, count, 0.0), np.where(ok, mean, 0.0), np.where(ok, sq, 0.0))
    std = np.sqrt(np.clip(sq - mean**2, 0, None))
    return {"ages": ages[ok], "count": count[ok], "mean": mean[ok] * scale, "std": std[ok] * scale, "r": r}


def age_scatter_figure(series: Sequence[tuple[str, Row]], unit: str = "mm²", scale: float = 1e6) -> Any:
    """Area ``4 σ_x σ_y`` over the number of observations of the track, one series per
    ``(label, row)``: mean ± std per age, marker area ∝ predictions, Pearson r in the legend."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    positive = []
    for k, (label, row) in enumerate(series):
        s = age_series(row, scale)
        if not len(s["ages"]):
            continue
        size = 80 * s["count"] / max(float(s["count"].max()), 1.0) + 4
        ax.errorbar(s["ages"], s["mean"], yerr=s["std"], fmt="none", ecolor=f"C{k}", alpha=0.35, lw=0.8)
        ax.scatter(s["ages"], s["mean"], s=size, color=f"C{k}", label=f"{label} (r = {s['r']:.2f})")
        positive += [v for v in s["mean"] if v > 0]
    if positive and max(positive) / min(positive) > 30:
        ax.set_yscale("log")
    ax.set_xlabel("number of observations of the track")
    ax.set_ylabel(f"bounding-box area 4·σx·σy ({unit})")
    ax.set_title(
        "predicted covariance size over the track's age (mean ± std; marker ∝ predictions)", fontsize=9
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def _slug(setting: Sequence[tuple[str, Any]]) -> str:
    text = params_text(setting)
    return re.sub(r"[^A-Za-z0-9.=-]+", "_", text).strip("_") or "default"


def predictor_figures(env_rows: Sequence[Row], out: Any) -> list[Any]:
    """The plot kinds of this module for one env's rows that carry their keys; the paths written.

    ``<env>_track_error_box[_<setting>].png`` per setting with per-track errors,
    ``<env>_reliability.png`` (rows with a calibration factor other than 1, before and after, at
    the first setting that has them) and ``<env>_aleatoric_age.png`` (rows whose area varies).
    """
    if not env_rows:
        return []
    env_id = env_rows[0].env_id
    scale, unit = unit_scale(env_id)
    paths = []
    with_box = [r for r in env_rows if box_stats(r) is not None]
    settings = list(dict.fromkeys(r.setting for r in with_box))
    for setting in settings:
        entries = [(row_label(r), r) for r in with_box if r.setting == setting]
        name = f"{env_id}_track_error_box" + (f"_{_slug(setting)}" if len(settings) > 1 else "") + ".png"
        title = f"{env_id}: per-track prediction error, true associations\n{params_text(setting)}"
        paths.append(save_figure(box_figure(entries, title, unit, scale), out / name))
    calibrated = [
        r
        for r in env_rows
        if len(reliability_points(r, raw=True)[0]) and r.mean.get("calibration_scale", 1) != 1
    ]
    if calibrated:
        first = calibrated[0].setting
        panels = []
        for r in (r for r in calibrated if r.setting == first):
            panels += [
                (f"{row_label(r)}: before calibration", r, True),
                (f"{row_label(r)}: calibrated", r, False),
            ]
        fig = reliability_figure(panels, f"{env_id}: reliability ({params_text(first)})")
        paths.append(save_figure(fig, out / f"{env_id}_reliability.png"))
    varying = [r for r in env_rows if math.isfinite(r.mean.get("aleatoric_area_r", math.nan))]
    if varying:
        first = varying[0].setting
        series = [(row_label(r), r) for r in varying if r.setting == first]
        fig = age_scatter_figure(series, unit + "²", scale * scale)
        paths.append(save_figure(fig, out / f"{env_id}_aleatoric_age.png"))
    return paths
