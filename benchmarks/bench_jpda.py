"""JPDA tracker frame time at ≈150 particles in view: against gnn in the same run, against Stone Soup's
JPDA tracker on the same stream, the gating-cluster sizes, and where a frame's time goes.

    python benchmarks/bench_jpda.py [--frames 300] [--warm 50] [--repeat 3] [--ss-frames 8]
                                    [--no-stone-soup] [--no-belt]

1. **Streams.** (a) The dense synthetic stream of ``bench_tracker.py``: 150 targets on a grid at
   ≈1.2 m/s (±0.05 m/s), 0.1 mm noise, every target detected, rows shuffled. (b) BeltSorter-v0
   with ``BeltParams(feed_rate=470, feed_burstiness=0)`` (≈150 particles in view; touching ones
   are one merged blob), driven by gnn + kf-ca as in ``bench_tracker.py``'s whole loop; its
   observations are recorded first, then every tracker runs on the recorded observations only.
2. **gnn against jpda.** gnn and jpda with kf-cv and kf-ca, jpda with ``merge_model`` True and
   False: ``--warm`` untimed frames (after ``warm_up()``), then every frame timed on its own; the
   median and mean of the repetition with the least total time (best of ``--repeat``, the
   trackers interleaved). jpda's ``last_cluster_tracks`` (tracks per gating cluster that holds a
   track) over the timed frames, and the tracks that fell back to loopy belief propagation.
3. **Stone Soup.** Stone Soup's ``MultiTargetMixtureTracker`` with ``JPDAwithEHM`` /
   ``JPDAwithEHM2`` (exact; plain ``JPDA`` enumerates the product of every track's hypotheses with
   no clustering: ≥ 2^150 joint events here) and ``PDAHypothesiser`` on the synthetic stream:
   constant-velocity model with kf-cv's ``q``, ``LinearGaussian`` measurement with the same R,
   jpda's ``p_D``, clutter density ``λ`` and ``P_G``. Both trackers hold the same 150 tracks: Stone
   Soup starts from the state of a plain-JPDA jpda + kf-cv tracker (``merge_model=False,
   coalescence_guard=False``: the same association as Stone Soup's) after frame
   ``--warm`` (means and covariances), no initiator (every target stays in view) and an
   ``UpdateTimeStepsDeleter(3)``. ``--ss-frames`` frames are timed one repetition each (seconds
   per frame); jpda on the same frames, best of ``--repeat``. The detections are converted to
   Stone Soup ``Detection`` objects before the clock starts. The estimates of both after the last
   frame are compared (max distance, the same track ids).
4. **Where the time goes.** One jpda run per predictor with every stage of a frame wrapped by a
   timer, and ``jpda_frame`` alone re-run on the inputs captured from the stream.

Timings from ``time.perf_counter``; ratios are against trackers timed in this run. The BLAS
library that ran (threadpoolctl, if installed) and the load average are printed.
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_tracker import SPEC, synthetic_observations

import agents.tracking.tracker as gnn_module
import track_envs  # noqa: F401
from agents import make_agent
from agents.jpda import _kernels as jpda_kernels
from track_envs.envs.belt_physics import BeltParams
from track_envs.values.types import SensorSpec

Obs = dict[str, NDArray]
#: jpda as plain JPDA (no merged blobs, every settled track by its mixture): Stone Soup's association.
PLAIN_JPDA = {"predictor": "kf-cv", "merge_model": False, "coalescence_guard": False}
#: The trackers of part 2: (label, agent name, keywords).
TRACKERS: list[tuple[str, str, dict[str, Any]]] = [
    ("gnn + kf-cv", "gnn", {"predictor": "kf-cv"}),
    ("gnn + kf-ca", "gnn", {"predictor": "kf-ca"}),
    ("jpda + kf-cv", "jpda", {"predictor": "kf-cv"}),
    ("jpda + kf-cv, merge_model=False", "jpda", {"predictor": "kf-cv", "merge_model": False}),
    ("jpda + kf-ca", "jpda", {"predictor": "kf-ca"}),
    ("jpda + kf-ca, merge_model=False", "jpda", {"predictor": "kf-ca", "merge_model": False}),
]


def machine_note() -> str:
    """Load average and the BLAS library numpy runs (threadpoolctl when installed)."""
    one, five, _ = os.getloadavg()
    try:
        from threadpoolctl import threadpool_info

        blas = "; ".join(
            f"{i['internal_api']} {i['version']} ({i.get('architecture', '?')} kernels, "
            f"{i['num_threads']} threads)"
            for i in threadpool_info()
            if i["user_api"] == "blas"
        )
    except ImportError:
        cfg = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
        blas = f"{cfg['name']} {cfg['version']} (threadpoolctl not installed: running kernel unknown)"
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs; BLAS: {blas}"


def belt_stream(frames: int, seed: int = 0) -> tuple[SensorSpec, list[Obs], float]:
    """Observations of BeltSorter-v0 at a feed of 470 particles/s driven by gnn + kf-ca, and the
    mean number of particles in view."""
    env = gym.make(
        "BeltSorter-v0",
        physics=BeltParams(feed_rate=470.0, feed_burstiness=0.0),
        max_detections=512,
        max_tracks=512,
        max_targets=512,
    )
    obs, _ = env.reset(seed=seed)
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    driver = make_agent("gnn", predictor="kf-ca")
    driver.reset(spec)
    out, in_view = [], []
    for _ in range(frames):
        out.append({k: np.array(v) for k, v in obs.items()})
        obs, _, _, _, info = env.step(driver.act(obs))
        in_view.append(int(np.sum(info["truth"]["visible"])))
    return spec, out, float(np.mean(in_view))


def make(name: str, kwargs: dict[str, Any], spec: SensorSpec) -> Any:
    agent = make_agent(name, **kwargs)
    agent.reset(spec)
    return agent


def run_timed(agent: Any, observations: list[Obs], warm: int) -> tuple[NDArray, list[int], int]:
    """Per-frame times (s) after ``warm`` untimed frames; jpda's cluster sizes and the tracks that
    fell back to loopy belief propagation over the timed frames."""
    for obs in observations[:warm]:
        agent.act(obs)
    approx0 = getattr(agent, "approximate_tracks", 0)
    times = np.empty(len(observations) - warm)
    sizes: list[int] = []
    for k, obs in enumerate(observations[warm:]):
        start = time.perf_counter()
        agent.act(obs)
        times[k] = time.perf_counter() - start
        if hasattr(agent, "last_cluster_tracks"):
            sizes.extend(agent.last_cluster_tracks.tolist())
    return times, sizes, getattr(agent, "approximate_tracks", 0) - approx0


def compare(
    observations: list[Obs], spec: SensorSpec, warm: int, repeat: int
) -> dict[str, tuple[NDArray, list[int], int, int]]:
    """Best-of-``repeat`` frame times of every tracker in `TRACKERS` (interleaved)."""
    for _, name, kwargs in TRACKERS:  # load every kernel before any clock starts
        make(name, kwargs, spec).warm_up()
    best: dict[str, tuple[NDArray, list[int], int, int]] = {}
    for _ in range(repeat):
        for label, name, kwargs in TRACKERS:
            agent = make(name, kwargs, spec)
            times, sizes, approx = run_timed(agent, observations, warm)
            if label not in best or times.sum() < best[label][0].sum():
                best[label] = (times, sizes, approx, agent.n_tracks)
    return best


def histogram(sizes: list[int]) -> str:
    counts = np.bincount(sizes) if sizes else np.zeros(1, int)
    return ", ".join(f"{k}: {c}" for k, c in enumerate(counts) if c)


def print_compare(title: str, best: dict[str, tuple[NDArray, list[int], int, int]], frames: int) -> None:
    print(f"\n| {title} | median µs | mean µs | p99 µs | tracks | jpda/gnn (median, mean) |")
    print("|---|---|---|---|---|---|")
    for label, (times, _, _, tracks) in best.items():
        ratio = "-"
        if label.startswith("jpda"):
            ref = best["gnn + " + label.split(" + ")[1].split(",")[0]][0]
            ratio = f"{np.median(times) / np.median(ref):.2f}x, {times.mean() / ref.mean():.2f}x"
        print(
            f"| {label} | {np.median(times) * 1e6:.0f} | {times.mean() * 1e6:.0f} | "
            f"{np.percentile(times, 99) * 1e6:.0f} | {tracks} | {ratio} |"
        )
    print(f"\ntracks per gating cluster (clusters holding a track, over the {frames} timed frames):")
    for label, (_, sizes, approx, _) in best.items():
        if label.startswith("jpda"):
            print(
                f"- {label}: {histogram(sizes)}; {len(sizes) / frames:.1f} clusters per frame; "
                f"tracks by loopy belief propagation: {approx}"
            )


# -- Stone Soup ---------------------------------------------------------------------------------
def stone_soup_compare(observations: list[Obs], warm: int, frames: int, repeat: int) -> None:
    """Stone Soup's JPDA tracker against jpda + kf-cv on the same frames (module docstring, 3.)."""
    try:
        from stonesoup.dataassociator.probability import JPDAwithEHM, JPDAwithEHM2
        from stonesoup.deleter.time import UpdateTimeStepsDeleter
        from stonesoup.hypothesiser.probability import PDAHypothesiser
        from stonesoup.initiator.base import Initiator
        from stonesoup.models.measurement.linear import LinearGaussian
        from stonesoup.models.transition.linear import (
            CombinedLinearGaussianTransitionModel,
            ConstantVelocity,
        )
        from stonesoup.predictor.kalman import KalmanPredictor
        from stonesoup.tracker.simple import MultiTargetMixtureTracker
        from stonesoup.types.detection import Detection
        from stonesoup.types.state import GaussianState
        from stonesoup.types.track import Track
        from stonesoup.updater.kalman import KalmanUpdater
    except ImportError:
        print("\nStone Soup is not installed (pip install stonesoup==1.9.1): its comparison is skipped")
        return

    class NoBirths(Initiator):
        """Every target of the synthetic stream stays in view: no track starts."""

        def initiate(self, detections: Any, timestamp: Any, **kwargs: Any) -> set:
            return set()

    # the reference state: jpda + kf-cv as plain JPDA (no merged blobs, no coalescence guard),
    # after frame `warm`
    ref = make("jpda", PLAIN_JPDA, SPEC)
    for obs in observations[: warm + 1]:
        ref.act(obs)
    q = float(ref.predictor.q)
    R = ref._noise_cov()
    ids0 = ref._ids.copy()
    perm = [0, 2, 1, 3]  # ours [x, y, vx, vy] -> Stone Soup's [x, vx, y, vy]
    mean0 = ref._state.mean[:, perm].copy()
    cov0 = ref._state.cov[:, perm][:, :, perm].copy()
    t0 = datetime.datetime(2026, 12, 2)
    stamp = [t0 + datetime.timedelta(seconds=k * SPEC.dt) for k in range(len(observations))]
    mm = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    frame_range = range(warm + 1, warm + 1 + frames)
    detections = {
        k: {
            Detection(z[:, None].astype(np.float64), timestamp=stamp[k], measurement_model=mm)
            for z in observations[k]["detections"][observations[k]["mask"] > 0]
        }
        for k in frame_range
    }
    print(
        f"\nStone Soup on the synthetic stream: {len(ids0)} tracks from jpda + kf-cv's state after "
        f"frame {warm}, frames {frame_range.start}..{frame_range.stop - 1}; q = {q:g}, "
        f"R = {R[0, 0]:.1e} I, p_D = {ref.p_detect:g}, λ = {ref.clutter_density:.2e}, P_G = {ref.p_gate:g}"
    )
    rows: list[tuple[str, NDArray, float]] = []
    for cls in (JPDAwithEHM, JPDAwithEHM2):
        updater = KalmanUpdater(mm)
        hypothesiser = PDAHypothesiser(
            predictor=KalmanPredictor(transition),
            updater=updater,
            clutter_spatial_density=ref.clutter_density,
            prob_detect=ref.p_detect,
            prob_gate=ref.p_gate,
        )
        tracker = MultiTargetMixtureTracker(
            initiator=NoBirths(),
            deleter=UpdateTimeStepsDeleter(time_steps_since_update=3),
            detector=None,
            data_associator=cls(hypothesiser),
            updater=updater,
        )
        tracks = {
            int(i): Track([GaussianState(m[:, None], c, timestamp=stamp[warm])], id=str(int(i)))
            for i, m, c in zip(ids0, mean0, cov0, strict=True)
        }
        tracker._tracks |= set(tracks.values())
        times = np.empty(frames)
        for n, k in enumerate(frame_range):
            start = time.perf_counter()
            tracker.update_tracker(stamp[k], detections[k])
            times[n] = time.perf_counter() - start
            print(f"  {cls.__name__} frame {k}: {times[n]:.2f} s", flush=True)
        ss_pos = {int(t.id): np.asarray(t.state_vector[[0, 2], 0], float) for t in tracker.tracks}
        rows.append((f"Stone Soup {cls.__name__} (MultiTargetMixtureTracker)", times, len(ss_pos)))
        last_ss = ss_pos
    ours: dict[str, NDArray] = {}
    for label, kwargs in (
        ("jpda + kf-cv", {"predictor": "kf-cv"}),
        ("jpda + kf-cv, plain JPDA (merge_model=False, coalescence_guard=False)", PLAIN_JPDA),
    ):
        make("jpda", kwargs, SPEC).warm_up()
        for _ in range(repeat):
            agent = make("jpda", kwargs, SPEC)
            for obs in observations[: warm + 1]:
                agent.act(obs)
            times = np.empty(frames)
            for n, k in enumerate(frame_range):
                start = time.perf_counter()
                report = agent.act(observations[k])
                times[n] = time.perf_counter() - start
            if label not in ours or times.sum() < ours[label].sum():
                ours[label] = times
        rows.append((label, ours[label], int(report["mask"].sum())))
        if kwargs.get("merge_model") is False:
            live = report["mask"] > 0
            pos = dict(zip(report["ids"][live].tolist(), report["positions"][live], strict=True))
            common = sorted(set(pos) & set(last_ss))
            gap = max(float(np.linalg.norm(pos[i] - last_ss[i])) for i in common)
            print(
                f"after frame {frame_range.stop - 1}: {len(common)} common track ids; largest distance "
                "between Stone Soup JPDAwithEHM2's and plain jpda's estimate "
                f"{gap * 1e6:.3g} µm"
            )
    ref_mean = ours["jpda + kf-cv"].mean()
    print(
        f"\n| synthetic stream, frames {frame_range.start}–{frame_range.stop - 1} "
        "| median ms/frame | mean ms/frame | tracks | × jpda + kf-cv (mean) |"
    )
    print("|---|---|---|---|---|")
    for label, times, n_tracks in rows:
        print(
            f"| {label} | {np.median(times) * 1e3:.3f} | {times.mean() * 1e3:.3f} | {n_tracks} | "
            f"{times.mean() / ref_mean:,.0f}x |"
        )


# -- where the time goes -----------------------------------------------------------------------
class StageTimer:
    """Wraps callables so that their time per frame accumulates under a name."""

    def __init__(self) -> None:
        self.now: dict[str, float] = {}
        self.frames: dict[str, list[float]] = {}
        self.restore: list[Callable[[], None]] = []

    def wrap(self, owner: Any, attr: str, name: str, on_instance: bool = False) -> None:
        fn = getattr(owner, attr)

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.now[name] = self.now.get(name, 0.0) + time.perf_counter() - start

        setattr(owner, attr, timed)
        if on_instance:
            self.restore.append(lambda: delattr(owner, attr))
        else:
            self.restore.append(lambda: setattr(owner, attr, fn))

    def end_frame(self, names: list[str]) -> None:
        for name in names:
            self.frames.setdefault(name, []).append(self.now.get(name, 0.0))
        self.now = {}

    def undo(self) -> None:
        for fn in reversed(self.restore):
            fn()


def capture_frames(
    kwargs: dict[str, Any], observations: list[Obs], spec: SensorSpec, warm: int
) -> list[tuple[Any, ...]]:
    """The arguments of every ``jpda_frame`` call of a jpda run after ``warm`` frames (copies)."""
    agent = make("jpda", kwargs, spec)
    frame_fn = jpda_kernels.jpda_frame
    captured: list[tuple[Any, ...]] = []

    def capture(*args: Any) -> Any:
        captured.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        return frame_fn(*args)

    for obs in observations[:warm]:
        agent.act(obs)
    jpda_kernels.jpda_frame = capture
    try:
        for obs in observations[warm:]:
            agent.act(obs)
    finally:
        jpda_kernels.jpda_frame = frame_fn
    return captured


#: The stages of a frame in the profile: (row text, timer name).
STAGES = [
    ("observation check", "check"),
    ("predict", "predict"),
    ("jpda_frame kernel (gate, merged-blob pairs, clusters, marginals, moments)", "jpda_frame kernel"),
    ("split blobs (kernel)", "split blobs"),
    ("second chance (`SecondChance.recover`)", "second chance"),
    ("rest of the association (Python, arrays; gnn: gate, cost, assignment)", "association rest"),
    ("update (PDA update of the mixture / Kalman update)", "update"),
    ("upkeep (misses, deletions)", "upkeep"),
    ("velocity prior (`FlowPrior.learn`)", "learn flow"),
    ("births (`_initiate`)", "initiate"),
    ("nozzle-bar roll-out (`_predict_sorting`)", "sorting"),
    ("estimate, report", "report"),
    ("rest of `act()` (Python; ≈0.2 µs per timer)", "rest"),
]


def profile(
    name: str, kwargs: dict[str, Any], observations: list[Obs], spec: SensorSpec, warm: int
) -> dict[str, float]:
    """Median µs per frame of each stage of one tracker's frame (module docstring, 4.)."""
    agent = make(name, kwargs, spec)
    agent.warm_up()
    timer = StageTimer()
    timer.wrap(gnn_module, "check_observation", "check")
    timer.wrap(gnn_module._kernels, "frame_upkeep", "upkeep")
    timer.wrap(agent.predictor, "predict", "predict", on_instance=True)
    for attr, stage in (
        ("_associate_frame", "associate"),
        ("_update_tracks", "update"),
        ("_initiate", "initiate"),
        ("_report", "report"),
        ("_estimate_mean", "report"),
        ("_predict_sorting", "sorting"),
    ):
        timer.wrap(agent, attr, stage, on_instance=True)
    timer.wrap(agent._prior, "learn", "learn flow", on_instance=True)
    timer.wrap(agent.associator.second_chance, "recover", "second chance", on_instance=True)
    if name == "jpda":
        timer.wrap(jpda_kernels, "jpda_frame", "jpda_frame kernel")
        timer.wrap(jpda_kernels, "split_blobs", "split blobs")
    names = [key for _, key in STAGES if key not in ("association rest", "rest")] + ["associate"]
    totals: list[float] = []
    try:
        for k, obs in enumerate(observations):
            start = time.perf_counter()
            agent.act(obs)
            total = time.perf_counter() - start
            timer.end_frame(names)
            if k >= warm:
                totals.append(total)
    finally:
        timer.undo()
    per = {s: np.asarray(v[warm:]) for s, v in timer.frames.items()}
    per["association rest"] = (
        per["associate"] - per["jpda_frame kernel"] - per["split blobs"] - per["second chance"]
    )
    per["rest"] = np.asarray(totals) - sum(per[key] for _, key in STAGES if key != "rest")
    out = {key: float(np.median(per[key])) * 1e6 for _, key in STAGES}
    if name != "jpda":
        del out["jpda_frame kernel"], out["split blobs"]
    out["whole frame (with the timers), median"] = float(np.median(totals)) * 1e6
    out["whole frame (with the timers), mean"] = float(np.mean(totals)) * 1e6
    if name == "jpda":
        captured = capture_frames(kwargs, observations, spec, warm)
        variants: tuple[tuple[str, int | None, float | None], ...] = (
            ("jpda_frame alone, captured inputs", None, None),
            ("the same, merge_extent=0", 6, 0.0),
            ("the same, max_exact=0 (gating, merged-blob pairs, clusters; no marginals)", 10, 0),
        )
        for label, index, value in variants:
            alone = np.empty(len(captured))
            for k, args in enumerate(captured):
                if index is not None:
                    args = (*args[:index], value, *args[index + 1 :])
                best = np.inf
                for _ in range(3):
                    start = time.perf_counter()
                    jpda_kernels.jpda_frame(*args)
                    best = min(best, time.perf_counter() - start)
                alone[k] = best
            out[label + " (best of 3 per frame), median"] = float(np.median(alone)) * 1e6
            if index is None:
                worst = int(np.argmax(alone))
                biggest = int(jpda_kernels.jpda_frame(*captured[worst]).cluster_tracks.max())
                out["the same, slowest frame"] = float(alone.max()) * 1e6
                out["largest cluster of the slowest frame (tracks)"] = float(biggest)
        one = captured[0]
        tiny = (one[0][:1], one[1][:1], one[2][:1], *one[3:11], one[11][:1])
        best = np.inf
        for _ in range(200):
            start = time.perf_counter()
            jpda_kernels.jpda_frame(*tiny)
            best = min(best, time.perf_counter() - start)
        out["jpda_frame on a 1-track, 1-detection frame (call overhead), best of 200"] = best * 1e6
    return out


def print_profiles(title: str, observations: list[Obs], spec: SensorSpec, warm: int) -> None:
    """One table: the stages of gnn's and jpda's frame, median µs over the timed frames."""
    configs = [(label, name, kwargs) for label, name, kwargs in TRACKERS if label != "gnn + kf-cv"]
    cols = [profile(name, kwargs, observations, spec, warm) for _, name, kwargs in configs]
    print(f"\n| {title}: median µs/frame | " + " | ".join(label for label, _, _ in configs) + " |")
    print("|---" * (len(configs) + 1) + "|")
    extra = [key for c in cols for key in c if key not in dict((k, t) for t, k in STAGES)]
    rows = STAGES + [(key, key) for key in dict.fromkeys(extra)]
    for text, key in rows:
        cells = [f"{c[key]:.1f}" if key in c else "-" for c in cols]
        print(f"| {text} | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=300, help="timed frames per stream")
    parser.add_argument("--warm", type=int, default=50, help="untimed frames before the clock starts")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--ss-frames", type=int, default=8, help="frames timed for Stone Soup")
    parser.add_argument("--no-stone-soup", action="store_true")
    parser.add_argument("--no-belt", action="store_true")
    args = parser.parse_args()
    print(machine_note())
    synthetic = synthetic_observations(args.warm + args.frames, seed=0)
    best = compare(synthetic, SPEC, args.warm, args.repeat)
    print_compare("synthetic stream, 150 tracks × 150 detections", best, args.frames)
    if not args.no_belt:
        spec, belt, in_view = belt_stream(args.warm + args.frames)
        dets = np.mean([obs["mask"].sum() for obs in belt[args.warm :]])
        print(
            f"\nBeltSorter-v0 at 470 particles/s: {in_view:.0f} particles in view, "
            f"{dets:.0f} detections per frame (touching particles are one blob)"
        )
        best = compare(belt, spec, args.warm, args.repeat)
        print_compare(f"BeltSorter-v0, {in_view:.0f} in view, {dets:.0f} detections", best, args.frames)
    if not args.no_stone_soup:
        stone_soup_compare(synthetic, args.warm, args.ss_frames, args.repeat)
    print("\nwhere the time goes (one instrumented run each, medians over the timed frames):")
    print_profiles("synthetic stream", synthetic, SPEC, args.warm)
    if not args.no_belt:
        print_profiles("BeltSorter-v0 stream", belt, spec, args.warm)
    print("\n" + machine_note())


if __name__ == "__main__":
    main()
