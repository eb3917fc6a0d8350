"""Claims of Pollithy et al. (2020), Sec. V, against the records of the ``pollithy2020`` suite.

Pollithy, Reith-Braun, Pfaff, Hanebeck, "Estimating Uncertainties of Recurrent Neural Networks in
Application to Multitarget Tracking" (MFI 2020).
[`write_claims`][track_apps.bench.claims.pollithy2020.write_claims] draws our analogues of their Figs. 3–4, 6,
7, 8 and Table I from the records of ``track bench run --suite pollithy2020`` and writes ``pollithy2020.md``:
one row per claim with the paper's figure and number, ours, and a verdict computed by the rule stated in the
row (``holds`` / ``partly`` / ``does not hold``).

    track bench claims pollithy2020 results/pollithy2020 --out docs
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from track_apps.bench.claims._pollithy2020_rows import (
    FIG6,
    FIG7,
    KINDS,
    NAME,
    NO_ERRORS,
    NOISE,
    PAPER_TABLE1,
    VARIANTS,
    Claim,
    fig6_row,
    fig7_row,
    in_mm,
    noise_series,
    table1_row,
    track_error_median,
)
from track_apps.bench.claims._pollithy2020_text import INTRO, discussion
from track_apps.bench.figures import age_scatter_figure, age_series, box_figure, box_stats, reliability_figure
from track_apps.bench.rows import Row, aggregate, save_figure
from track_envs.infra.atomic import write_text


# -- figures -------------------------------------------------------------------------------------
def noise_figure(rows: Sequence[Row], variant: str, title: str) -> Any:
    """e_mean, e1 and e2 over the added noise (mm), one curve per Fig. 7 contestant, ± std bands."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4.0))
    for ax, metric in zip(axes, ("e_mean", "e1", "e2"), strict=True):
        for k, (label, predictor, kwargs) in enumerate(FIG7):
            pts = [(n, r) for n in NOISE if (r := fig7_row(rows, predictor, kwargs, n, variant)) is not None]
            if not pts:
                continue
            x = np.array([n * 1e3 for n, _ in pts])
            m = np.array([r.mean.get(metric, math.nan) for _, r in pts])
            s = np.array([r.std.get(metric, math.nan) for _, r in pts])
            ax.plot(x, m, marker="o", ms=3, color=f"C{k}", label=f"{label} (n={pts[0][1].n})")
            ax.fill_between(x, np.maximum(m - s, 0), m + s, color=f"C{k}", alpha=0.15)
        ax.set_xlabel("added measurement noise std (mm)")
        ax.set_ylabel(metric + " (fraction)")
        ax.set_title(metric)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return fig


def write_figures(rows: Sequence[Row], figdir: Path) -> dict[str, Path]:
    """Every figure the records allow; name → path."""
    import matplotlib

    matplotlib.use("Agg")
    figdir.mkdir(parents=True, exist_ok=True)
    out: dict[str, Path] = {}
    for kind in KINDS:
        entries = [(label, r) for label, p, kw in FIG6 if (r := fig6_row(rows, p, kw, kind)) is not None]
        if entries:
            title = (
                f"Fig. 6 analogue: BeltSorter-v0 {kind}s, 0.1 mm noise, true associations\n"
                f"(learned models trained on cylinders; mean of {entries[0][1].n} seeds' quantiles)"
            )
            out[f"fig6_{kind}"] = save_figure(
                box_figure(entries, title), figdir / f"fig6_track_error_{kind}.png"
            )
    for name, (_, text, _) in VARIANTS.items():
        if any(fig7_row(rows, p, kw, n, name) for _, p, kw in FIG7 for n in NOISE):
            title = f"Fig. 7 analogue: gnn tracker on BeltSorter-v0 ({text}); mean ± std over seeds"
            out[name] = save_figure(noise_figure(rows, name, title), figdir / f"{name}_e_mean.png")
    nll = fig6_row(rows, "nll-lstm", (), "cylinder")
    mc = fig6_row(rows, "mc-lstm", (("samples", 250),), "cylinder")
    panels = []
    for label, r in (("nll-lstm", nll), ("mc-lstm T=250", mc)):
        if r is not None:
            panels += [
                (f"{label}: before calibration", r, True),
                (f"{label}: calibrated (r = {r.mean['calibration_scale']:.3g})", r, False),
            ]
    if panels:
        fig = reliability_figure(
            panels, "Figs. 3–4 analogue: reliability on held-out cylinder episodes (0.1 mm noise)"
        )
        out["fig3_4"] = save_figure(fig, figdir / "fig3_4_reliability.png")
    series = [
        (label, r)
        for label, r in (("nll-lstm, 0.1 mm noise", nll), ("nll-lstm, no added noise", table1_row(rows, 0.0)))
        if r is not None
    ]
    if series:
        fig = age_scatter_figure(series)
        fig.axes[0].set_title(
            "Fig. 8 analogue: nll-lstm aleatoric area over the track's age (cylinders)", fontsize=9
        )
        out["fig8"] = save_figure(fig, figdir / "fig8_aleatoric_age.png")
    return out


# -- claims --------------------------------------------------------------------------------------


def _count_verdict(wins: int, n: int) -> str:
    """``holds`` when ``wins == n``, ``partly`` from half of ``n`` on, ``no data`` for ``n = 0``."""
    return _verdict(None if n == 0 else wins == n, wins >= n / 2)


def _verdict(ok: bool | None, partly: bool = False) -> str:
    if ok is None:
        return "no data"
    return "holds" if ok else ("partly" if partly else "does not hold")


def _dropout_note() -> str:
    """The dropout rate of the shipped mc-lstm and the share of its samples that drop nothing."""
    from predictors import make_predictor

    p = float(make_predictor("mc-lstm", samples=1).dropout)  # type: ignore[attr-defined]
    if p <= 0:
        return ""
    width = 2 * 2 + 64 + 64 + 32 + 32  # inputs and both layers' input and recurrent units
    clean = (1 - p) ** width
    return (
        f"The shipped mc-lstm drops units with p = {100 * p:.2g}% (the best rate of its training grid), "
        f"so {100 * clean:.0f}% of the T samples drop no unit at all and equal the plain network."
    )


def fig6_claims(rows: Sequence[Row], fig: str) -> list[Claim]:
    med = {label: track_error_median(fig6_row(rows, p, kw, "cylinder")) for label, p, kw in FIG6}
    have = {k: v for k, v in med.items() if not math.isnan(v)}
    out = []
    if not have:
        return [Claim("Fig. 6 claims", "Fig. 6", fig, "no records", "no data", "")]
    text = ", ".join(f"{k} {in_mm(v)}" for k, v in have.items())
    p95 = {
        label: (fig6_row(rows, p, kw, "cylinder") or Row("", (), "", "", 0, {}, {})).mean.get(
            "track_error_p95", math.nan
        )
        for label, p, kw in FIG6
    }
    below = all(v < 3e-4 for v in have.values())
    out.append(
        Claim(
            "Errors of all models are of comparable size; most tracks' mean error is below 0.3 mm",
            "all medians < 0.3 mm (peppercorns)",
            fig,
            f"median per-track error (mm), cylinders: {text}",
            _verdict(below, any(v < 3e-4 for v in have.values())),
            "rule: every median below 0.3 mm. 95th percentiles (mm): "
            + ", ".join(f"{k} {in_mm(v)}" for k, v in p95.items() if not math.isnan(v)),
        )
    )
    mc = [(t, med.get(f"mc-lstm T={t}", math.nan)) for t in (10, 100, 250, 1000)]
    mc = [(t, v) for t, v in mc if not math.isnan(v)]
    if len(mc) >= 2:
        gain = (mc[0][1] - mc[-1][1]) / mc[0][1]
        out.append(
            Claim(
                "MC-dropout accuracy depends on the sample size T (better with more samples)",
                "errors fall with T = 10 … 1000",
                fig,
                "median (mm): "
                + ", ".join(f"T={t} {in_mm(v)}" for t, v in mc)
                + f" ({100 * gain:+.2f}% from the first to the last T)",
                _verdict(gain > 0.01, gain > 0.002),
                "rule: median at the largest T at least 1% below the smallest T's (partly: 0.2–1%). "
                + _dropout_note(),
            )
        )
    kfca = min(med.get("kf-ca", math.nan), med.get("kf-ca, q tuned", math.nan))
    if mc and not math.isnan(kfca):
        out.append(
            Claim(
                "Even T = 1000 samples predict worse than the constant-acceleration Kalman filter",
                "mc-lstm (T=1000) > KF-CA",
                fig,
                f"mc-lstm T={mc[-1][0]} {in_mm(mc[-1][1])} mm vs best kf-ca {in_mm(kfca)} mm",
                _verdict(mc[-1][1] > kfca),
                "rule: median of mc-lstm at the largest T above the better kf-ca (default or tuned q).",
            )
        )
    kf = (
        min(v for k, v in have.items() if k.startswith("kf-"))
        if any(k.startswith("kf-") for k in have)
        else math.nan
    )
    learned = min(med.get("lstm", math.nan), med.get("nll-lstm", math.nan))
    if not (math.isnan(kf) or math.isnan(learned)):
        out.append(
            Claim(
                "The LSTM and the NLL-LSTM do not predict better than the Kalman filters",
                "LSTM, NLL-LSTM ≥ KF",
                fig,
                f"best LSTM median {in_mm(learned)} mm vs best Kalman filter {in_mm(kf)} mm",
                _verdict(learned >= kf),
                "rule: the better LSTM's median not below the best Kalman filter's (default or tuned q).",
            )
        )
    per_kind = []
    for kind in KINDS:
        a, b = (
            track_error_median(fig6_row(rows, "nll-lstm", (), kind)),
            track_error_median(fig6_row(rows, "lstm", (), kind)),
        )
        if not (math.isnan(a) or math.isnan(b)):
            per_kind.append((kind, a, b))
    if per_kind:
        gaps = [(b - a) / b for _, a, b in per_kind]
        out.append(
            Claim(
                "The NLL-LSTM predicts significantly better than the standard LSTM",
                "NLL-LSTM < LSTM",
                fig,
                "; ".join(
                    f"{k}: nll-lstm {in_mm(a)} vs lstm {in_mm(b)} mm ({100 * g:+.1f}%)"
                    for (k, a, b), g in zip(per_kind, gaps, strict=True)
                ),
                _verdict(all(g >= 0.05 for g in gaps), all(g > 0 for g in gaps)),
                "rule: nll-lstm's median at least 5% below lstm's on every particle kind "
                "(partly: below, by less).",
            )
        )
    return out


TIE_NOTE = (
    f" Levels where both (or all) e_mean are below {NO_ERRORS:g} are ties and not counted; "
    "with none left the claim cannot be tested on this belt."
)


def _compare(a: np.ndarray, b: np.ndarray) -> tuple[int, int]:
    """Levels where ``a < b`` and the levels counted (finite, not both below
    [`NO_ERRORS`][track_apps.bench.claims.pollithy2020.NO_ERRORS])."""
    ok = np.isfinite(a) & np.isfinite(b) & ~((a < NO_ERRORS) & (b < NO_ERRORS))
    return int(np.sum(a[ok] < b[ok])), int(ok.sum())


def _tested(wins: int, n: int) -> str:
    return "untestable (no association errors)" if n == 0 else _count_verdict(wins, n)


def fig7_claims(rows: Sequence[Row], links: dict[str, str]) -> list[Claim]:
    out = []
    for variant, name in links.items():
        e = {label: [fig7_row(rows, p, kw, n, variant) for n in NOISE] for label, p, kw in FIG7}
        if not any(r is not None for rs in e.values() for r in rs):
            continue
        val = {
            k: np.array([math.nan if r is None else r.mean.get("e_mean", math.nan) for r in rs])
            for k, rs in e.items()
        }
        where = VARIANTS[variant][2]
        nll, lstm, cv, mc = (
            val["nll-lstm"],
            val["lstm (line-searched s·I)"],
            val["kf-cv"],
            val["mc-lstm T=250"],
        )
        wins, n = _compare(nll, lstm)
        out.append(
            Claim(
                f"The NLL-LSTM makes fewer association errors than the line-searched LSTM ({where})",
                "e_mean NLL-LSTM < LSTM over 0–0.5 mm",
                name,
                f"lower at {wins} of {n} noise levels; e_mean nll-lstm: {noise_series(nll)}; "
                f"lstm: {noise_series(lstm)}",
                _tested(wins, n),
                "rule: lower at every noise level (partly: at half of them or more)." + TIE_NOTE,
            )
        )
        wins, n = _compare(nll, cv)
        out.append(
            Claim(
                f"Learned uncertainties improve association over the CV Kalman filter ({where})",
                "NLL-LSTM below KF-CV (Fig. 7)",
                name,
                f"nll-lstm lower than kf-cv at {wins} of {n} noise levels; kf-cv: {noise_series(cv)}",
                _tested(wins, n),
                "rule: lower at every noise level (partly: at half of them or more)." + TIE_NOTE,
            )
        )
        if not np.isfinite(mc).any():
            continue
        others = np.vstack([v for k, v in val.items() if k != "mc-lstm T=250"])
        ok = np.isfinite(mc) & np.isfinite(others).all(axis=0)
        ok &= np.maximum(mc, np.nanmax(np.where(np.isfinite(others), others, 0.0), axis=0)) >= NO_ERRORS
        worst = int(np.sum(mc[ok] >= np.nanmax(others[:, ok], axis=0))) if ok.any() else 0
        out.append(
            Claim(
                f"The dropout LSTM (T = 250) is inferior to the other methods ({where})",
                "highest e_mean of all",
                name,
                f"highest e_mean at {worst} of {int(ok.sum())} noise levels; mc-lstm: {noise_series(mc)}",
                _tested(worst, int(ok.sum())),
                "rule: the highest e_mean at every noise level (partly: at half of them or more)." + TIE_NOTE,
            )
        )
    return out


def reliability_claims(rows: Sequence[Row], fig: str) -> list[Claim]:
    nll = fig6_row(rows, "nll-lstm", (), "cylinder")
    mc = fig6_row(rows, "mc-lstm", (("samples", 250),), "cylinder")
    if nll is None or mc is None:
        return [Claim("Figs. 3–4 claims", "Figs. 3–4", fig, "no records", "no data", "")]
    a, b = nll.mean["calibration_error_raw"], mc.mean["calibration_error_raw"]
    inside = mc.mean.get("reliability_raw@0.20", math.nan)
    ca, cb = nll.mean["calibration_error"], mc.mean["calibration_error"]
    ga, gb = nll.mean.get("reliability_raw@0.999", math.nan), mc.mean.get("reliability_raw@0.999", math.nan)

    def gate(row: Row) -> float:
        return row.mean.get("reliability@0.999", math.nan)

    need_a = a > 0.05 or abs(ga - 0.999) > 0.001
    need_b = b > 0.05 or abs(gb - 0.999) > 0.001
    return [
        Claim(
            "Uncalibrated, the NLL-LSTM is closer to the diagonal than the dropout LSTM",
            "Fig. 3 vs Fig. 4",
            fig,
            f"mean |empirical − expected| before calibration: nll-lstm {a:.3f}, mc-lstm {b:.3f}",
            _verdict(a < b),
            "rule: smaller mean distance from the diagonal over the levels 0.01, 0.05 … 0.95, 0.99, 0.999.",
        ),
        Claim(
            "The uncalibrated dropout LSTM overestimates its uncertainty: > 98% inside the 0.2 region",
            "> 0.98 at p = 0.2",
            fig,
            f"empirical level at p = 0.2 before calibration: {inside:.3f}",
            _verdict(inside > 0.98, inside > 0.2),
            "rule: above 0.98 (partly: above 0.2, i.e. over-estimated but less).",
        ),
        Claim(
            "Calibration is necessary for both models",
            "both curves off the diagonal",
            fig,
            f"distance from the diagonal before → after calibration: nll-lstm {a:.3f} → {ca:.3f}, "
            f"mc-lstm {b:.3f} → {cb:.3f}",
            _verdict(need_a and need_b, need_a or need_b),
            f"rule: each uncalibrated curve is more than 0.05 from the diagonal on average or misses the "
            f"gate level (coverage at p = 0.999 before → after: nll-lstm {ga:.4f} → {gate(nll):.4f}, "
            f"mc-lstm {gb:.4f} → {gate(mc):.4f}) by more than 0.001. The factor r is fitted at "
            "p = 0.999 only (Sec. IV-E), so the calibrated curve need not be near the diagonal elsewhere.",
        ),
    ]


def aleatoric_claims(rows: Sequence[Row], fig8: str) -> list[Claim]:
    out = []
    nll = fig6_row(rows, "nll-lstm", (), "cylinder")
    if nll is not None:
        r = age_series(nll)["r"]
        out.append(
            Claim(
                "The aleatoric area falls with the number of observations of a track",
                "r = −0.59 (peppercorns)",
                fig8,
                f"Pearson r = {r:.2f} (nll-lstm, cylinders, 0.1 mm noise, every prediction)",
                _verdict(r < -0.3, r < 0),
                "rule: r below −0.3 (partly: negative).",
            )
        )
    areas = [
        (n, r.mean["aleatoric_area_mean"] * 1e6) for n in NOISE if (r := table1_row(rows, n)) is not None
    ]
    if len(areas) >= 2:
        vals = [a for _, a in areas]
        rising = all(b > a for a, b in itertools.pairwise(vals))
        out.append(
            Claim(
                "The NLL-LSTM's aleatoric area grows with the added noise",
                "0.17 → 1.04 mm² for 0 → 0.5 mm",
                "Table I below",
                f"{vals[0]:.3f} → {vals[-1]:.3f} mm² for {areas[0][0] * 1e3:g} → {areas[-1][0] * 1e3:g} mm",
                _verdict(rising, vals[-1] > vals[0]),
                "rule: strictly increasing over the noise levels (partly: the last above the first).",
            )
        )
    return out


def table1(rows: Sequence[Row]) -> list[str]:
    lines = [
        "| added noise std (mm) | paper: mean aleatoric area (mm², peppercorns) "
        "| ours: nll-lstm raw 4σxσy (mm²) | ours, calibrated (× r) | predictions | seeds |",
        "|---|---|---|---|---|---|",
    ]
    for n in NOISE:
        r = table1_row(rows, n)
        if r is None:
            continue
        a = r.mean["aleatoric_area_mean"] * 1e6
        scale = r.mean.get("calibration_scale", 1.0)
        lines.append(
            f"| {n * 1e3:.1f} | {PAPER_TABLE1[round(n * 1e3, 1)]:.4f} | {a:.4f} | {a * scale:.4f} "
            f"| {r.mean['aleatoric_n']:.0f} per seed | {r.n} |"
        )
    return lines


def fig6_table(rows: Sequence[Row]) -> list[str]:
    lines = [
        "| model | " + " | ".join(f"{k}: p25 / median / p75 (mm)" for k in KINDS) + " |",
        "|---|" + "---|" * len(KINDS),
    ]
    for label, p, kw in FIG6:
        cells = []
        for kind in KINDS:
            r = fig6_row(rows, p, kw, kind)
            s = None if r is None else box_stats(r, 1e3)
            cells.append("–" if s is None else f"{s['q1']:.3f} / {s['med']:.3f} / {s['q3']:.3f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def fig7_table(rows: Sequence[Row], variant: str) -> list[str]:
    noise = [n for n in NOISE if any(fig7_row(rows, p, kw, n, variant) for _, p, kw in FIG7)]
    lines = [
        "| model | " + " | ".join(f"{n * 1e3:.1f} mm" for n in noise) + " |",
        "|---|" + "---|" * len(noise),
    ]
    for label, p, kw in FIG7:
        cells = []
        for n in noise:
            r = fig7_row(rows, p, kw, n, variant)
            cells.append(
                "–"
                if r is None
                else f"{r.mean['e_mean']:.4f} ± {r.std['e_mean']:.4f} "
                f"(e1 {r.mean['e1']:.3f}, e2 {r.mean['e2']:.3f})"
            )
        if any(c != "–" for c in cells):
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def load_stats(records: Sequence[dict[str, Any]]) -> str:
    """Frames and wall time of the records (sum of the cells' own times)."""
    wall = sum(float(r.get("timing", {}).get("wall_s", 0.0)) for r in records)
    frames = sum(int(r.get("timing", {}).get("frames", 0)) for r in records)
    return f"{len(records)} cells, {frames:,} frames, {wall / 60:.1f} min of cell time (summed over workers)"


def write_claims(
    records: Sequence[dict[str, Any]], out: str | Path, *, wall_s: float | None = None, label: str = ""
) -> list[Path]:
    """The figures into ``<out>/figures/pollithy2020/`` and ``<out>/pollithy2020.md``; their paths."""
    out = Path(out)
    rows = aggregate(records)
    figdir = out / "figures" / NAME
    figs = write_figures(rows, figdir)

    def rel(key: str) -> str:
        return f"[{figs[key].name}](figures/{NAME}/{figs[key].name})" if key in figs else "(no records)"

    claims = [
        *fig6_claims(rows, rel("fig6_cylinder")),
        *fig7_claims(rows, {v: rel(v) for v in VARIANTS}),
        *reliability_claims(rows, rel("fig3_4")),
        *aleatoric_claims(rows, rel("fig8")),
    ]

    lines = [f"# Reproducing Pollithy et al. (2020) on BeltSorter-v0{label}", "", *INTRO, ""]
    lines += [
        f"Records: {load_stats(records)}"
        + (f"; wall time of the run: {wall_s / 60:.1f} min." if wall_s else "."),
        "",
    ]
    lines += [
        "## Claims",
        "",
        "| # | claim (paper) | paper's figure / number | our figure | our number | verdict "
        "| how it is judged, notes |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, c in enumerate(claims, 1):
        lines.append(f"| {i} | {c.claim} | {c.paper} | {c.figure} | {c.ours} | **{c.verdict}** | {c.note} |")
    lines += ["", "## Fig. 6: per-track mean absolute prediction error, true associations", ""]
    lines += [
        f"![Fig. 6 cylinders](figures/{NAME}/{figs['fig6_cylinder'].name})"
        if "fig6_cylinder" in figs
        else "",
        "",
    ]
    lines += fig6_table(rows)
    for key, (_, title, _) in VARIANTS.items():
        if key in figs:
            lines += [
                "",
                f"## Fig. 7: tracker e_mean over the added noise, {title}",
                "",
                f"![{key}](figures/{NAME}/{figs[key].name})",
                "",
            ]
            lines += ["e_mean ± std over seeds (e1, e2 means):", "", *fig7_table(rows, key)]
    if "fig3_4" in figs:
        lines += [
            "",
            "## Figs. 3–4: reliability before and after calibration",
            "",
            f"![reliability](figures/{NAME}/{figs['fig3_4'].name})",
        ]
    if "fig8" in figs:
        lines += [
            "",
            "## Fig. 8: aleatoric area over the number of observations",
            "",
            f"![fig8](figures/{NAME}/{figs['fig8'].name})",
        ]
    lines += ["", "## Table I: aleatoric area over the added noise", "", *table1(rows)]
    lines += [
        "",
        "## Where our belt differs, and why we think it does",
        "",
        *discussion(rows, claims, len(records)),
        "",
    ]
    path = out / f"{NAME}.md"
    write_text(path, "\n".join(lines))
    return [path, *figs.values()]
