"""The okada2020 ablation (Okada et al. 2020, Table II) from track bench records: a table and a bar chart.

Reads the records of ``track bench run --suite okada2020 --out DIR`` and prints, per variant,
nose ``id_switches`` (Table II's num_switches) and total MOTA as mean ± std over the seeds, with
the paper's figures beside them, and writes a bar chart of both.

Usage::

    python benchmarks/okada2020_table.py DIR [--plot docs/okada2020.png]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from track_envs.infra.atomic import save_figure

#: Table II of Okada et al. (2020): (label, aleatoric, epistemic, L) → (MOTA total, num_switches).
PAPER = {
    ("both", 15): (66.1, 232),
    ("both", 10): (66.2, 213),
    ("both", 7): (66.1, 242),
    ("both", 3): (66.0, 266),
    ("aleatoric only", 10): (66.1, 252),
    ("epistemic only", 10): (66.0, 285),
    ("none", 10): (65.9, 303),
    ("baseline", None): (65.4, 407),
}
ORDER = list(PAPER)


def variant(cell: dict) -> tuple[str, int | None]:
    """The Table II row of a record's cell."""
    if cell["agent"] == "pose-baseline":
        return ("baseline", None)
    kw = cell["agent_kwargs"]
    a, e = kw.get("aleatoric", True), kw.get("epistemic", True)
    label = {(True, True): "both", (True, False): "aleatoric only", (False, True): "epistemic only"}.get(
        (a, e), "none"
    )
    return (label, int(kw.get("window", 10)))


def collect(directory: Path) -> dict[tuple[str, int | None], dict[str, list[float]]]:
    out: dict[tuple[str, int | None], dict[str, list[float]]] = {}
    for path in sorted(directory.glob("*.json")):
        record = json.loads(path.read_text())
        if "cell" not in record or record["cell"]["env_id"] != "KeypointWalkers-v0":
            continue
        row = out.setdefault(variant(record["cell"]), {"switches": [], "mota": [], "fps": [], "seed": []})
        row["model"] = record["cell"]["agent_kwargs"].get("model", "pose-lstm-walkers")  # type: ignore[assignment]
        row["seed"].append(record["cell"]["seed"])
        row["switches"].append(record["metrics"]["id_switches_nose"])
        row["mota"].append(100 * record["metrics"]["mota"])
        row["fps"].append(record["timing"]["frames_per_s"])
    return out


def paired(rows: dict, shown: list) -> None:
    """Per-seed nose switches of every variant, and its paired difference to "both, L = 10" with a
    95 % t-interval of the mean difference (the seeds' scenes differ far more than the variants)."""
    from scipy import stats

    both = ("both", 10)
    if both not in rows:
        return
    ref = dict(zip(rows[both]["seed"], rows[both]["switches"], strict=True))
    print(
        "\n| variant | model | frames / s | switches per seed | total | minus both, L = 10: mean [95 % CI] |"
    )
    print("|---|---|---|---|---|---|")
    for key in shown:
        r = rows[key]
        by_seed = dict(zip(r["seed"], r["switches"], strict=True))
        seeds = sorted(by_seed)
        per = " ".join(f"{by_seed[k]:.0f}" for k in seeds)
        diff = np.array([by_seed[k] - ref[k] for k in seeds if k in ref], dtype=float)
        ci = "–"
        if key != both and len(diff) > 1:
            half = stats.t.ppf(0.975, len(diff) - 1) * diff.std(ddof=1) / np.sqrt(len(diff))
            worse, better = int(np.sum(diff > 0)), int(np.sum(diff < 0))
            mean = diff.mean()
            ci = f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]; worse on {worse}, better on {better}"
        model = r.get("model", "-") if key[0] != "baseline" else "-"
        total = sum(by_seed.values())
        fps = np.mean(r["fps"])
        label = f"{key[0]}, L = {key[1]}" if key[1] else key[0]
        print(f"| {label} | {model} | {fps:.2f} | {per} | {total:.0f} | {ci} |")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args(argv)
    rows = collect(args.dir)
    base = np.mean(rows[("baseline", None)]["switches"]) if ("baseline", None) in rows else np.nan
    print("| variant | L | paper MOTA | paper switches (/ baseline) | ours MOTA | ours nose switches", end="")
    print(" | / baseline | seeds |")
    print("|---|---|---|---|---|---|---|---|")
    shown = [k for k in ORDER if k in rows]
    for key in shown:
        r = rows[key]
        pm, ps = PAPER[key]
        s, m = np.array(r["switches"]), np.array(r["mota"])
        print(
            f"| {key[0]} | {key[1] or '-'} | {pm} | {ps} ({ps / 407:.2f}) | {m.mean():.1f} ± {m.std():.1f} | "
            f"{s.mean():.1f} ± {s.std():.1f} | {s.mean() / base:.2f} | {len(s)} |"
        )
    paired(rows, shown)
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        labels = [f"{k[0]}\nL={k[1]}" if k[1] else k[0] for k in shown]
        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
        for ax, metric, title in (
            (axes[0], "switches", "nose id switches"),
            (axes[1], "mota", "MOTA total (%)"),
        ):
            vals = [np.mean(rows[k][metric]) for k in shown]
            errs = [np.std(rows[k][metric]) for k in shown]
            ax.bar(range(len(shown)), vals, yerr=errs, capsize=3, color="tab:blue")
            ax.set_xticks(range(len(shown)), labels, fontsize=7, rotation=45, ha="right")
            ax.set_title(title)
        fig.suptitle("okada2020 ablation on KeypointWalkers-v0 (mean ± std over seeds)")
        fig.tight_layout()
        args.plot.parent.mkdir(parents=True, exist_ok=True)
        save_figure(fig, args.plot, dpi=100)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
