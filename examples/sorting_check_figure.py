"""The truth-free sorting check on the shipped detection sample: figures, a table and a plot.

python examples/sorting_check_figure.py --out docs/figures/sorting_from_recordings

For each predictor (gnn agent), ``agents.sorting.check.check_sorting`` on the sample (200 frames
of BeltSorter-v0 detections, metres, 100 Hz, 0.1 mm noise) with the virtual line at ``x = 0.35``
and predictions from ``x <= 0.30`` (5 cm, the BeltSorter-v0 nozzle bar's distance), then the hit
rate and lateral error over cut-offs from 2 to 14 cm before the line. ``--truth`` also runs the
check on a fresh BeltSorter-v0 episode (the sample's settings, seed 1), where the particle behind
every detection is known, and scores the same predictions against the simulator's true crossings:
how far the truth-free figures are from the true ones.
Prints a markdown table and writes ``sorting_check.png``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import track_envs  # noqa: F401  (registers the environments)
from agents import make_agent
from agents.sorting import SortingCheck, check_sorting
from track_envs import Detections, detection_sensor_spec
from track_envs.envs import SAMPLE_NOISE_STD, SAMPLE_READ_OPTIONS, sample_detections_path
from track_envs.io import read_detections, save_figure

LINE, CUT = 0.35, 0.30
DISTANCES = (0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.14)


def belt_episode(n_frames: int, line: float, seed: int = 1) -> tuple[Detections, dict[str, Any]]:
    """A BeltSorter-v0 episode like the sample's (defaults) but with its truth: the detections
    (with the particle behind each, ``Detections.ids``) and each particle's true first crossing of
    ``line`` (``particle``, ``t``, ``y``, interpolated between the frames around it)."""
    import gymnasium as gym

    from track_envs.contracts import empty_report
    from track_envs.envs import recorded_crossings

    env = gym.make("BeltSorter-v0")
    obs, info = env.reset(seed=seed)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))  # type: ignore[attr-defined]
    points, owners, times, truth = [], [], [], []
    for _ in range(n_frames):
        live = obs["mask"] == 1
        points.append(obs["detections"][live].astype(np.float64))
        owners.append(info["detection_ids"][live])
        times.append(info["t"])
        ids = info["truth"]["ids"]
        truth.append((ids[ids >= 0], info["truth"]["positions"][ids >= 0]))
        obs, _, _, _, info = env.step(report)
    detections = Detections.from_frames(points, times=np.asarray(times))
    detections = Detections(
        detections.points, detections.offsets, np.concatenate(owners), times=detections.times
    )
    n_ids = max(int(ids.max(initial=-1)) for ids, _ in truth) + 1
    dense = np.full((n_frames, n_ids, 2), np.nan)
    for k, (ids, positions) in enumerate(truth):
        dense[k, ids] = positions
    _, particle, t, y = recorded_crossings(dense, line, detections.inferred_dt() or 0.01)
    first = np.unique(particle, return_index=True)[1]
    return detections, {"particle": particle[first], "t": t[first], "y": y[first]}


def truth_score(
    result: SortingCheck, detections: Detections, truth: dict[str, Any], min_seen: int = 3
) -> dict:
    """The check's predictions scored against the simulator's crossings, with the check's rules
    (a prediction's particle: the one behind the last detection it starts from)."""
    owner = detections.ids
    upstream = owner[(detections.points[:, 0] <= result.cut) & (owner >= 0)]
    ids, counts = np.unique(upstream, return_counts=True)
    scored = np.intersect1d(ids[counts >= min_seen], truth["particle"])
    p = result.predictions
    particle = owner[result.seen]
    keep = np.isin(particle, scored)
    # the last prediction per particle
    rows = np.flatnonzero(keep)
    _, last = np.unique(particle[rows][::-1], return_index=True)
    rows = rows[::-1][last]
    at = np.searchsorted(truth["particle"], particle[rows])
    dt = p.t[rows] - truth["t"][at]
    dy = p.y[rows] - truth["y"][at]
    hits = (np.abs(dt) <= result.score.time_tolerance) & (np.abs(dy) <= result.score.lateral_tolerance)
    return {
        "crossings": len(scored),
        "hit_rate": float(hits.sum() / len(scored)),
        "time_p90_ms": float(np.percentile(np.abs(dt), 90) * 1000),
        "lateral_p90_mm": float(np.percentile(np.abs(dy), 90) * 1000),
    }


def truth_rows(predictors: list[str], n_frames: int = 200) -> list[dict[str, Any]]:
    """The truth-free check and the true score of the same predictions, on a BeltSorter-v0 episode."""
    detections, truth = belt_episode(n_frames, LINE)
    spec = detection_sensor_spec(detections, measurement_noise_std=SAMPLE_NOISE_STD)
    rows = []
    for name in predictors:
        result = check_sorting(make_agent("gnn", predictor=name), detections, spec, LINE, CUT)
        s = result.score.summary("m")
        true = truth_score(result, detections, truth)
        rows.append(
            {
                "predictor": name,
                "crossings": int(s["crossings"]),
                "true_crossings": true["crossings"],
                "hit_rate": s["hit_rate"],
                "true_hit_rate": true["hit_rate"],
                "time_p90_ms": s["time_p90_ms"],
                "true_time_p90_ms": true["time_p90_ms"],
                "lateral_p90_mm": 1000 * s["lateral_p90_m"],
                "true_lateral_p90_mm": true["lateral_p90_mm"],
            }
        )
    return rows


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--predictors", default="kf-cv,kf-ca,lstm,nll-lstm", help="comma list")
    parser.add_argument("--distances", default=",".join(map(str, DISTANCES)), help="line - cut values (m)")
    parser.add_argument("--truth", action="store_true", help="also score against the simulator's truth")
    parser.add_argument("--out", default="docs/figures/sorting_from_recordings", help="folder of the PNG")
    args = parser.parse_args(argv)
    predictors = [p for p in args.predictors.split(",") if p]
    distances = [float(d) for d in args.distances.split(",") if d]

    detections = read_detections(sample_detections_path(), "wide", **SAMPLE_READ_OPTIONS)
    spec = detection_sensor_spec(detections, measurement_noise_std=SAMPLE_NOISE_STD)
    main_results: dict[str, SortingCheck] = {}
    curves: dict[str, list[dict[str, float]]] = {}
    rows = []
    for name in predictors:
        agent = make_agent("gnn", predictor=name)
        reference = None
        curve = []
        for d in distances:
            result = check_sorting(agent, detections, spec, LINE, LINE - d, reference=reference)
            curve.append(result.score.summary("m"))
            if reference is None:  # the reference run does not depend on the cut-off: once
                from agents import run_agent

                reference = run_agent(agent, detections, spec)
        curves[name] = curve
        result = check_sorting(agent, detections, spec, LINE, CUT, reference=reference)
        main_results[name] = result
        s = result.score.summary("mm")
        row = {
            "predictor": name,
            "crossings": int(s["crossings"]),
            "hit_rate": s["hit_rate"],
            "time_p50_ms": s["time_p50_ms"],
            "time_p90_ms": s["time_p90_ms"],
            "time_p99_ms": s["time_p99_ms"],
            "lateral_p50_mm": 1000 * s["lateral_p50_mm"],
            "lateral_p90_mm": 1000 * s["lateral_p90_mm"],
            "lateral_p99_mm": 1000 * s["lateral_p99_mm"],
            "never_crossed": int(s["never_crossed"]),
            "nees": s["nees"],
        }
        rows.append(row)

    print_table(rows)
    if args.truth:
        print("\nthe same check on a BeltSorter-v0 episode (seed 1), and against its truth:")
        print_table(truth_rows(predictors))
    path = Path(args.out) / "sorting_check.png"
    plot(path, main_results, curves, distances)
    print(f"wrote {path}")
    for name, curve in curves.items():
        print(
            name,
            "hit rate by line - cut-off:",
            {f"{100 * d:g} cm": round(c["hit_rate"], 3) for d, c in zip(distances, curve, strict=True)},
        )
    return {"rows": rows, "curves": curves, "png": str(path)}


def print_table(rows: list[dict[str, Any]]) -> None:
    """The rows as a markdown table."""
    keys = list(rows[0])
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in rows:
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()]
        print("| " + " | ".join(cells) + " |")


def plot(
    path: Path,
    results: dict[str, SortingCheck],
    curves: dict[str, list[dict[str, float]]],
    distances: list[float],
) -> None:
    """Hit rate and lateral error over the extrapolated distance; temporal errors at the 5 cm cut-off."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    cm = np.asarray(distances) * 100
    for name, curve in curves.items():
        axes[0].plot(cm, [c["hit_rate"] for c in curve], marker="o", label=name)
        line = axes[2].plot(cm, [1000 * c["lateral_p90_m"] for c in curve], marker="o", label=f"{name} p90")
        axes[2].plot(cm, [1000 * c["lateral_p50_m"] for c in curve], ls="--", color=line[0].get_color())
    axes[0].set(
        xlabel="line − cut-off (cm)",
        ylabel="hit rate",
        title=f"hit rate, line x = {LINE} m",
        ylim=(0, 1.02),
    )
    axes[0].legend(fontsize=8)
    bins = np.linspace(-4, 4, 41)
    for name, result in results.items():
        axes[1].hist(1000 * result.score.time_error, bins=bins, histtype="step", label=name, linewidth=1.2)
    tol = next(iter(results.values())).score
    for sign in (-1, 1):
        axes[1].axvline(sign * 1000 * tol.time_tolerance, color="grey", linestyle=":")
    axes[1].set(xlabel="t̂ − t_c (ms)", ylabel="predictions", title=f"temporal error, cut-off x = {CUT} m")
    axes[2].axhline(1000 * tol.lateral_tolerance, color="grey", linestyle=":")
    axes[2].set(
        xlabel="line − cut-off (cm)",
        ylabel="|ŷ − y_c| (mm): p90 —, p50 - -",
        yscale="log",
        title="lateral error",
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
