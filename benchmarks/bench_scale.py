"""Frame time per target from 10² to 10⁵ targets in view: trackers, metrics, the env step, trackpy, laptrack.

    python benchmarks/bench_scale.py                      # N = 100 … 100,000, the figure and the table
    python benchmarks/bench_scale.py --sizes 150 1500     # some sizes only
    python benchmarks/bench_scale.py --compare-only       # trackpy / laptrack side by side (1,500, 15,000)
    python benchmarks/bench_scale.py --compare-only --compare-sizes 1500 --laptrack-without-gaps

The scene is the synthetic constant-velocity stream
([`track_envs.streams.constant_velocity`][track_envs.streams.constant_velocity]) at its default density: the
window grows with ``N`` (``(0.5, 0.3) · √(N/150)`` m) and so does the clutter (``5 N / 150`` per frame),
``p_D = 0.9``, σ = 0.1 mm, targets ≈3 cm apart moving 1 cm per frame. Every configuration runs in its own
process (``spawn``), on one thread, so that its peak resident memory is its own; its frames are timed one by
one after ``warm_up()`` and a settling period (``--settle`` frames: the field of tracks is full after ≈5), and
the median is reported.

1. **Trackers**: gnn kf-cv, gnn kf-ca, gnn nll-lstm and jpda kf-cv (``act()`` per frame), in ms per
   frame and µs per target, with the peak RSS of the process.
2. **Metrics**: the median ``update()`` per frame plus the episode's ``compute()`` spread over its
   frames, of e1/e2, CLEAR MOT with IDF1, GOSPA and HOTA, scoring the gnn kf-cv reports of the same
   stream against its truth.
3. **Env step**: BeltSorter-v0 by default and as the industrial-width belt, µs per particle in view.
4. **Side by side** (1,500 and 15,000): the gnn kf-cv, trackpy 0.7 (``link`` with
   ``NearestVelocityPredict``, search range = the gnn's gate radius) and laptrack 0.17 on the same
   detections: the whole stream's time over its frames and MOTA / IDF1 / HOTA from the project's
   scorers; trackpy and laptrack are skipped when they are not installed (``pip install -e .[compare]``).
   Every peer bridges the same gap, two missed detections in a row: the gnn coasts
   ``max_misses=2`` frames, trackpy keeps a particle ``memory=2`` frames, laptrack closes gaps of up
   to ``gap_closing_max_frame_count=3`` frames between a segment's end and the next one's start
   (`MISSES`). Each record holds its peer's settings (``settings``), printed beside its figures.

Records go to ``--out`` (``scale.json``), the log–log figure to ``--figure``; the table is printed.
Timings are medians of one run; the targets of the scale issue are read off as ratios against the
150-target cost of the same run.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from track_envs.infra.atomic import save_figure, write_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

#: Targets in view of the sizes the issue names.
SIZES = (100, 1_000, 10_000, 100_000)
#: The trackers of the table: (label, agent, keywords).
TRACKERS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("gnn kf-cv", "gnn", {"predictor": "kf-cv"}),
    ("gnn kf-ca", "gnn", {"predictor": "kf-ca"}),
    ("gnn nll-lstm", "gnn", {"predictor": "nll-lstm"}),
    ("jpda kf-cv", "jpda", {"predictor": "kf-cv"}),
)
#: The match distance of the scores (m): the belt's GOSPA cut-off, as score_tracker.
THRESHOLD = 0.005
#: The stream's mean velocity (m/s), its default: trackpy's first frame starts from it.
FLOW = np.array([1.0, 0.0])
#: Missed detections in a row that every peer of the side-by-side table bridges: the gnn's default
#: ``max_misses``, trackpy's ``memory``; laptrack's ``gap_closing_max_frame_count`` counts the frame
#: difference between a segment's end and the next segment's start, ``MISSES + 1``.
MISSES = 2


def single_thread() -> None:
    """One BLAS / OpenMP thread in this process (before numpy loads its BLAS)."""
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[name] = "1"


def stream_for(n: int, frames: int, seed: int = 0) -> Any:
    """The constant-velocity stream of ``n`` targets in view at the default density."""
    from track_envs.streams import constant_velocity_stream

    s = float(np.sqrt(n / 150.0))
    return constant_velocity_stream(
        np.random.default_rng(seed),
        n_targets=float(n),
        frames=frames,
        size=(0.5 * s, 0.3 * s),
        clutter_rate=5.0 * n / 150.0,
    )


def peak_rss_mb() -> float:
    """The process's peak resident set (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _time_tracker(label: str, agent_name: str, kwargs: dict[str, Any], n: int, frames: int, settle: int):
    """Child process: the per-frame ``act()`` times and (for gnn kf-cv) the metrics' update times."""
    single_thread()
    import track_envs  # noqa: F401
    from agents import make_agent
    from track_envs.metrics.defaults import point_metrics

    stream_for(100, 2)  # the sensor's kernels compiled / loaded before the timed generation
    t0 = time.perf_counter()
    stream = stream_for(n, frames)
    generate_s = time.perf_counter() - t0
    agent = make_agent(agent_name, **kwargs)
    agent.reset(stream.spec, seed=0)
    agent.warm_up()
    agent.reset(stream.spec, seed=0)
    metrics = point_metrics(THRESHOLD)
    act_s: list[float] = []
    metric_s: dict[str, list[float]] = {type(m).__name__: [] for m in metrics}
    tracks = []
    for frame, obs in enumerate(stream.observations):
        t0 = time.perf_counter()
        report = agent.act(obs)
        act_s.append(time.perf_counter() - t0)
        tracks.append(int(report["mask"].sum()))
        truth = stream.truth(frame)
        for metric in metrics:
            t0 = time.perf_counter()
            metric.update(truth, stream.detection_ids[frame], report)
            metric_s[type(metric).__name__].append(time.perf_counter() - t0)
    in_view = float(np.mean([len(ids) for ids in stream.truth_ids[settle:]]))
    record = {
        "kind": "tracker",
        "label": label,
        "n": n,
        "in_view": in_view,
        "tracks": float(np.mean(tracks[settle:])),
        "ms_per_frame": 1e3 * float(np.median(act_s[settle:])),
        "peak_rss_mb": peak_rss_mb(),
    }
    record["us_per_target"] = 1e3 * record["ms_per_frame"] / in_view
    scores: dict[str, float] = {}
    compute_s: dict[str, float] = {}
    for metric in metrics:
        t0 = time.perf_counter()
        scores.update({k: float(v) for k, v in metric.compute().items()})
        compute_s[type(metric).__name__] = time.perf_counter() - t0
    record.update({k: scores[k] for k in ("mota", "idf1", "hota", "e1", "e2")})
    out = [record]
    if label == "gnn kf-cv":
        ms = 1e3 * generate_s / frames
        out.append(
            {
                "kind": "env",
                "label": "constant-velocity stream",
                "n": n,
                "in_view": in_view,
                "ms_per_frame": ms,
                "us_per_target": 1e3 * ms / in_view,
            }
        )
    for name, times in metric_s.items() if label == "gnn kf-cv" else ():
        # a frame's share: its update, and the episode's compute() spread over the frames
        ms = 1e3 * (float(np.median(times[settle:])) + compute_s[name] / frames)
        out.append(
            {
                "kind": "metric",
                "label": name,
                "n": n,
                "in_view": in_view,
                "ms_per_frame": ms,
                "compute_ms": 1e3 * compute_s[name],
                "us_per_target": 1e3 * ms / in_view,
            }
        )
    return out


def _in_child(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` in a fresh spawned process (its own memory peak and compiled state)."""
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        return pool.apply(fn, args)


def _compare_linkers(n: int, frames: int, settle: int, without_gaps: bool = False) -> list[dict[str, Any]]:
    """Child process: trackpy and laptrack on the stream's detections, scored like the trackers
    (``without_gaps``: laptrack without gap closing too, the setting of earlier tables)."""
    single_thread()
    import pandas as pd

    from track_envs.contracts.report import pack_report
    from track_envs.metrics.clear_mot import ClearMot
    from track_envs.metrics.hota_stream import Hota

    stream = stream_for(n, frames)
    rows = []
    for t, obs in enumerate(stream.observations):
        live = obs["mask"].astype(bool)
        z = obs["detections"][live].astype(np.float64)
        rows.append(pd.DataFrame({"frame": t, "x": z[:, 0], "y": z[:, 1], "row": np.flatnonzero(live)}))
    detections = pd.concat(rows, ignore_index=True)
    search = gate_radius(stream, settle)
    out = [{**_linked_by_gnn(stream), "n": n}]
    step = FLOW * stream.spec.dt  # the flow's motion per frame (m)
    first = detections[detections["frame"] == 0][["x", "y"]].to_numpy()
    for name, (link, settings) in _linkers(search, step, first, without_gaps).items():
        if link is None:
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        linked = link(detections.copy())
        per_frame = (time.perf_counter() - t0) / len(stream.observations)
        cpu_per_frame = (time.process_time() - c0) / len(stream.observations)
        clear, hota = ClearMot(threshold=THRESHOLD), Hota(threshold=THRESHOLD)
        for t, group in linked.groupby("frame", sort=True):
            report = pack_report(
                group["particle"].to_numpy(np.int64),
                group[["x", "y"]].to_numpy(np.float64),
                group["row"].to_numpy(np.int64),
                max(len(group), 1),
            )
            truth = stream.truth(int(t))
            clear.update(truth, stream.detection_ids[int(t)], report)
            hota.update(truth, stream.detection_ids[int(t)], report)
        scores = {**clear.compute(), **hota.compute()}
        out.append(
            {
                "kind": "linker",
                "label": name,
                "n": n,
                "ms_per_frame": 1e3 * per_frame,
                "cpu_ms_per_frame": 1e3 * cpu_per_frame,
                "search_range": search,
                "settings": settings,
                "mota": float(scores["mota"]),
                "idf1": float(scores["idf1"]),
                "hota": float(scores["hota"]),
            }
        )
    return out


def _linked_by_gnn(stream: Any) -> dict[str, Any]:
    """The gnn kf-cv on the stream, timed as the linkers are (the whole stream over its frames,
    after ``warm_up()``) and scored by the same scorers."""
    from agents import make_agent
    from track_envs.metrics.clear_mot import ClearMot
    from track_envs.metrics.hota_stream import Hota

    agent = make_agent("gnn", predictor="kf-cv")
    agent.reset(stream.spec, seed=0)
    agent.warm_up()
    agent.reset(stream.spec, seed=0)
    assert agent.max_misses == MISSES, agent.max_misses
    clear, hota = ClearMot(threshold=THRESHOLD), Hota(threshold=THRESHOLD)
    spent = 0.0
    for t, obs in enumerate(stream.observations):
        t0 = time.perf_counter()
        report = agent.act(obs)
        spent += time.perf_counter() - t0
        for metric in (clear, hota):
            metric.update(stream.truth(t), stream.detection_ids[t], report)
    scores = {**clear.compute(), **hota.compute()}
    return {
        "kind": "linker",
        "label": "gnn kf-cv",
        "settings": f"defaults: max_misses={agent.max_misses}, p_gate={agent.p_gate}",
        "ms_per_frame": 1e3 * spent / len(stream.observations),
        "mota": float(scores["mota"]),
        "idf1": float(scores["idf1"]),
        "hota": float(scores["hota"]),
    }


def gate_radius(stream: Any, frames: int) -> float:
    """The gnn kf-cv's gate as a distance: ``sqrt(γ S₀₀)`` with the median predicted ``S₀₀`` of its
    tracks after ``frames`` frames of the stream (``γ`` the χ² gate at the default ``p_gate``)."""
    from agents import make_agent
    from agents.tracking.assign import chi2_gate

    agent = make_agent("gnn", predictor="kf-cv")
    agent.reset(stream.spec, seed=0)
    for obs in stream.observations[:frames]:
        agent.act(obs)
    cov = agent.last_prediction.cov
    return float(np.sqrt(chi2_gate(agent.p_gate, 2) * np.median(cov[:, 0, 0])))


def _linkers(
    search: float, step: np.ndarray, first: np.ndarray, without_gaps: bool = False
) -> dict[str, tuple[Callable[[Any], Any] | None, str]]:
    """trackpy's and laptrack's linking of a detection table and their settings (None: not installed).

    trackpy links with ``NearestVelocityPredict`` within ``search`` (the gnn's gate), its first frame's
    particles starting at the flow's velocity (``step`` per frame), as the gnn's velocity fallback;
    later particles take their neighbours' velocity; ``memory=MISSES``. laptrack has no motion model:
    it links consecutive frames within ``search + |step|`` (the gate around the position one frame of
    flow ahead), else nothing links, and closes gaps of up to ``MISSES`` missed frames (frame
    difference ``MISSES + 1``) within ``search + (MISSES + 1)·|step|``, the same rule over the gap.
    Its costs are squared distances, so both cutoffs are squared. ``without_gaps`` adds laptrack
    with gap closing off (``gap_closing_max_frame_count=0``), every miss ending its track.
    """
    linkers: dict[str, tuple[Callable[[Any], Any] | None, str]] = {
        "trackpy 0.7": (None, "not installed"),
        "laptrack 0.17": (None, "not installed"),
    }
    try:
        import trackpy
        from trackpy.predict import NearestVelocityPredict

        trackpy.quiet()

        def trackpy_link(df: Any) -> Any:
            predictor = NearestVelocityPredict(
                initial_guess_positions=first,
                initial_guess_vels=np.tile(step, (len(first), 1)),
                pos_columns=["x", "y"],
            )
            return predictor.link_df(df, search, pos_columns=["x", "y"], memory=MISSES)

        linkers["trackpy 0.7"] = (
            trackpy_link,
            f"NearestVelocityPredict, search_range={1e3 * search:.2f} mm, memory={MISSES}",
        )
    except ImportError:
        pass
    try:
        from laptrack import LapTrack

        speed = float(np.hypot(*step))
        reach = search + speed
        gap_frames = MISSES + 1
        gap_reach = search + gap_frames * speed

        def laptrack_link(df: Any, gaps: int = gap_frames) -> Any:
            lt = LapTrack(
                cutoff=reach**2,
                gap_closing_cutoff=gap_reach**2,
                gap_closing_max_frame_count=gaps,
                splitting_cutoff=False,
                merging_cutoff=False,
            )
            spots, _, _ = lt.predict_dataframe(df, ["x", "y"], only_coordinate_cols=False)
            return spots.rename(columns={"track_id": "particle"})

        linkers["laptrack 0.17"] = (
            laptrack_link,
            f"cutoff=({1e3 * reach:.2f} mm)², gap_closing_cutoff=({1e3 * gap_reach:.2f} mm)², "
            f"gap_closing_max_frame_count={gap_frames}",
        )
        if without_gaps:
            linkers["laptrack 0.17 no gaps"] = (
                lambda df: laptrack_link(df, gaps=0),
                f"cutoff=({1e3 * reach:.2f} mm)², gap_closing_max_frame_count=0",
            )
    except ImportError:
        pass
    return linkers


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--frames", type=int, default=40, help="frames per stream (default 40)")
    parser.add_argument("--settle", type=int, default=10, help="frames before timing (default 10)")
    parser.add_argument("--trackers", nargs="+", default=[t[0] for t in TRACKERS])
    parser.add_argument("--compare-sizes", type=int, nargs="*", default=[1_500, 15_000])
    parser.add_argument("--compare-only", action="store_true")
    parser.add_argument(
        "--laptrack-without-gaps",
        action="store_true",
        help="side by side: laptrack with gap closing off too (gap_closing_max_frame_count=0)",
    )
    parser.add_argument("--out", type=Path, default=Path("results/scale"))
    parser.add_argument("--figure", type=Path, default=None, help="the log-log figure (PNG)")
    parser.add_argument("--redraw", type=Path, default=None, help="draw --figure from a scale.json and stop")
    args = parser.parse_args()
    if args.redraw is not None:
        _figure(json.loads(args.redraw.read_text()), args.figure or args.redraw.with_suffix(".png"))
        return

    records: list[dict[str, Any]] = []
    if not args.compare_only:
        for n in args.sizes:
            for label, agent_name, kwargs in TRACKERS:
                if label not in args.trackers:
                    continue
                recs = _in_child(_time_tracker, label, agent_name, kwargs, n, args.frames, args.settle)
                for r in recs:
                    print(_line(r), flush=True)
                records += recs
    for n in args.compare_sizes:
        recs = _in_child(_compare_linkers, n, args.frames, args.settle, args.laptrack_without_gaps)
        for r in recs:
            print(_line(r), flush=True)
        records += recs
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "scale.json", json.dumps(records, indent=1))
    print(f"records: {args.out / 'scale.json'}")
    if args.figure is not None:
        _figure(records, args.figure)


def _line(r: dict[str, Any]) -> str:
    """One printed line of a record."""
    text = f"{r['kind']:8s} {r['label']:16s} N={r['n']:>7,d} {r['ms_per_frame']:10.3f} ms/frame"
    if "us_per_target" in r:
        text += f" {r['us_per_target']:8.2f} µs/target"
    if "cpu_ms_per_frame" in r:
        text += f" ({r['cpu_ms_per_frame']:.3f} ms CPU)"
    if "peak_rss_mb" in r:
        text += f" peak {r['peak_rss_mb']:8.0f} MB"
    if "idf1" in r:
        text += f" MOTA {r['mota']:.3f} IDF1 {r['idf1']:.3f} HOTA {r['hota']:.3f}"
    if "settings" in r:
        text += f"  [{r['settings']}]"
    return text


def _figure(records: list[dict[str, Any]], path: Path) -> None:
    """Log–log frame time per target against targets in view, one line per tracker / metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    styles = {"tracker": ("o-", "{}"), "metric": ("s--", "{} (metric)"), "env": ("^:", "{} (generation)")}
    for kind, label in sorted({(r["kind"], r["label"]) for r in records if "us_per_target" in r}):
        mine = [r for r in records if (r["kind"], r["label"]) == (kind, label)]
        x, y = zip(*sorted((r["in_view"], r["us_per_target"]) for r in mine), strict=True)
        style, name = styles[kind]
        ax.plot(x, y, style, label=name.format(label))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("targets in view")
    ax.set_ylabel("µs per target and frame")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(
        "Cost per target: the constant-velocity stream at its default density, one thread", fontsize=9
    )
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()
