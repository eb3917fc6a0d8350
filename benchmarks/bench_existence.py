"""Track existence under clutter: the point trackers against Stone Soup's confirming trackers.

    python benchmarks/bench_existence.py                                  # 20 targets, seeds 0-2
    python benchmarks/bench_existence.py --stonesoup GNN --region-deleter # + our region deletion
    python benchmarks/bench_existence.py --targets 100 --peers none       # the project's trackers only

The scene is the synthetic constant-velocity stream
([`track_envs.streams.constant_velocity`][track_envs.streams.constant_velocity])
at the default density of targets (``constant_density(N)``: ``N`` in view, targets ≈3 cm apart
moving 1 cm a frame, σ = 0.1 mm), 300 frames, at three sensor settings ``(p_D, clutter)``:
``(0.9, 0)``, ``(0.75, 15)`` and ``(0.6, 40)`` clutter detections a frame at 100 targets, i.e. the
same clutter per area at every ``N`` (3 and 8 a frame at 20 targets).

Rows, on the same detections (identical positions, frame by frame):

* **ours**: gnn and jpda with kf-cv, given the stream's sensor spec, their reports as they are:
  today every unclaimed detection starts a track that is reported at once;
* **ours, post-hoc >= k**: the same reports filtered *after the run* to the tracks with >= k
  updates (report rows with a detection) over their whole life, every row of such a track kept,
  also those before its k-th update. It needs the future of each track, so it is an upper
  reference for a confirmation life cycle, not an online tracker;
* **Stone Soup 1.9.1** (``pip install stonesoup==1.9.1``, in the ``compare`` extra; skipped when
  it is not installed or with ``--peers none``): ``MultiTargetTracker`` with GNN
  (``GNNWith2DAssignment`` + ``DistanceHypothesiser``, Mahalanobis distance, missed distance
  ``sqrt(χ²₂(p_gate))`` = our gate) or ``MultiTargetMixtureTracker`` with ``JPDAwithEHM``
  (``PDAHypothesiser``, ``prob_gate = p_gate``, the spec's ``p_D`` and clutter density; EHM gives
  the exact JPDA marginals per cluster of tracks, where the plain ``JPDA`` enumerates the joint
  product over all tracks, ≈2²⁰ hypotheses a frame at 20 targets), each with
  ``MultiMeasurementInitiator(min_points=2 or 3)`` (its holding tracks associated by the same GNN)
  and ``UpdateTimeStepsDeleter(3)`` (deleted at the third miss in a row, as our ``max_misses=2``);
  with ``--region-deleter`` also deleted, as ours are, when a track that was not updated in the
  frame is predicted outside the window (without it a target that leaves is followed by two
  coasted rows outside the window, two false positives a target).
  The models are ours: constant velocity with white-noise acceleration ``q`` = kf-cv's (1 m²/s³;
  the stream's targets move without process noise), ``LinearGaussian`` measurement with the
  stream's σ, and new tracks start from the velocity prior our gnn learnt on the same stream
  (its mean, covariance ``diag(4 s² + (0.1 |v̄|)²)``). Scored two ways: **online**, the tracks the
  tracker holds after each frame (a track shows from its ``min_points``-th update), and
  **history**, online plus the held states before confirmation (post-hoc, like ours >= k).

Scores: CLEAR MOT (MOTA, IDF1) and HOTA from the project's metrics at the stream's match distance,
5 mm (the belt's GOSPA cut-off, as [`score_tracker`][track_envs.streams.constant_velocity.score_tracker]:
the stream is in metres); ``ids/targets``: distinct track ids reported over the stream per true
target; ms per frame: the tracker's whole stream over its frames (ours after ``warm_up()``), ours
and theirs timed in this run, in this process, on one BLAS thread; ``x ours``: the row's time per
frame over our tracker's with the same association (gnn or jpda). Every figure is the mean over
the seeds with the seeds' range in brackets. Records go to ``--out`` (``existence.json``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from track_envs.infra.atomic import write_text

#: ``(p_D, clutter detections a frame at 100 targets)`` of the three sensor settings.
CONDITIONS: tuple[tuple[float, float], ...] = ((0.9, 0.0), (0.75, 15.0), (0.6, 40.0))
#: The match distance of the scores (m): the belt's GOSPA cut-off, as ``score_tracker``.
THRESHOLD = 0.005
#: Update counts of the post-hoc filter and Stone Soup's ``min_points``.
MIN_POINTS = (2, 3)
#: Consecutive misses at which Stone Soup's deleter removes a track (ours: ``max_misses=2``).
DELETE_AFTER_MISSES = 3
#: Our trackers: (label, agent name).
OURS: tuple[tuple[str, str], ...] = (("gnn", "gnn"), ("jpda", "jpda"))

Frame = tuple[np.ndarray, np.ndarray]  # one frame's reported (ids (n,), positions (n, 2))


def machine_note() -> str:
    """Load average and the BLAS library numpy runs (threadpoolctl's running kernel)."""
    from threadpoolctl import threadpool_info

    one, five, _ = os.getloadavg()
    blas = "; ".join(
        f"{i['internal_api']} {i['version']} ({i.get('architecture', '?')} kernels, "
        f"{i['num_threads']} threads)"
        for i in threadpool_info()
        if i["user_api"] == "blas"
    )
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs; BLAS: {blas}"


def make_stream(n_targets: int, p_detect: float, clutter_at_100: float, frames: int, seed: int) -> Any:
    """The constant-velocity stream of ``n_targets`` in view at the default density of targets and
    ``clutter_at_100 · N / 100`` clutter detections a frame."""
    from track_envs.streams import constant_density, constant_velocity_stream

    kwargs = constant_density(float(n_targets))
    kwargs["clutter_rate"] = clutter_at_100 * n_targets / 100.0
    return constant_velocity_stream(np.random.default_rng(seed), frames=frames, p_detect=p_detect, **kwargs)


def score(stream: Any, frames: Sequence[Frame]) -> dict[str, float]:
    """MOTA, IDF1, HOTA at `THRESHOLD` and the distinct ids per true target of ``frames``."""
    from track_envs.contracts.report import pack_report
    from track_envs.metrics.clear_mot import ClearMot
    from track_envs.metrics.hota_stream import Hota

    clear, hota = ClearMot(threshold=THRESHOLD), Hota(threshold=THRESHOLD)
    for t, (ids, positions) in enumerate(frames):
        report = pack_report(ids, positions, np.full(len(ids), -1, dtype=np.int64), max(len(ids), 1))
        for metric in (clear, hota):
            metric.update(stream.truth(t), stream.detection_ids[t], report)
    scores = {**clear.compute(), **hota.compute()}
    reported = len(np.unique(np.concatenate([ids for ids, _ in frames]))) if frames else 0
    targets = len(np.unique(np.concatenate(stream.truth_ids)))
    return {
        "mota": float(scores["mota"]),
        "idf1": float(scores["idf1"]),
        "hota": float(scores["hota"]),
        "ids_per_target": reported / max(targets, 1),
    }


def run_ours(name: str, stream: Any) -> tuple[list[Frame], list[np.ndarray], float, Any]:
    """Our tracker ``name`` (kf-cv) over ``stream``: per frame the reported (ids, positions) and the
    ids updated in it, the mean ms per frame of ``act()`` (after ``warm_up()``), and the agent."""
    from agents import make_agent

    agent: Any = make_agent(name, predictor="kf-cv")
    agent.reset(stream.spec, seed=0)
    agent.warm_up()
    agent.reset(stream.spec, seed=0)
    frames: list[Frame] = []
    updated: list[np.ndarray] = []
    spent = 0.0
    for obs in stream.observations:
        t0 = time.perf_counter()
        report = agent.act(obs)
        spent += time.perf_counter() - t0
        live = report["mask"].astype(bool)
        ids = report["ids"][live].astype(np.int64)
        frames.append((ids, report["positions"][live].astype(np.float64)))
        updated.append(ids[report["detection"][live] >= 0])
    return frames, updated, 1e3 * spent / len(stream.observations), agent


def post_hoc(frames: Sequence[Frame], updated: Sequence[np.ndarray], k: int) -> list[Frame]:
    """``frames`` kept to the tracks with >= ``k`` updates over the whole stream (every row of them)."""
    counts: dict[int, int] = {}
    for ids in updated:
        for i in ids.tolist():
            counts[i] = counts.get(i, 0) + 1
    keep = np.array(sorted(i for i, c in counts.items() if c >= k), dtype=np.int64)
    out: list[Frame] = []
    for ids, positions in frames:
        rows = np.isin(ids, keep)
        out.append((ids[rows], positions[rows]))
    return out


def velocity_prior(agent: Any) -> tuple[np.ndarray, np.ndarray]:
    """The velocity prior ``agent`` learnt: the mean ``v̄`` (2,) and the start covariance of a new
    track's velocity, ``diag(4 s² + (0.1 |v̄|)²)``
    ([`agents.tracking.velocity_prior`][agents.tracking.velocity_prior])."""
    state = agent.velocity_prior_state
    if state.mean is None or state.variance is None:
        raise RuntimeError(f"the gnn learnt no velocity prior (source {state.source!r})")
    mean = np.asarray(state.mean, dtype=np.float64)
    return mean, np.diag(4.0 * np.asarray(state.variance) + (0.1 * float(np.linalg.norm(mean))) ** 2)


def stonesoup_version() -> str | None:
    """Stone Soup's version, its modules (and the BLAS they load) imported; None when it is not
    installed."""
    try:
        import stonesoup
        import stonesoup.dataassociator.probability
        import stonesoup.tracker.simple
    except ImportError:
        return None
    return str(stonesoup.__version__)


def region_deleter(low: Sequence[float], high: Sequence[float]) -> Any:
    """A Stone Soup deleter of the tracks that were not updated in the frame and whose predicted
    position lies outside ``[low, high]``: our trackers' region deletion (``region_margin=0``)."""
    from stonesoup.base import Property
    from stonesoup.deleter.base import Deleter
    from stonesoup.types.update import Update

    class OutsideRegionDeleter(Deleter):
        """Deletes a coasting track whose predicted position left the observed region."""

        low: tuple[float, float] = Property(doc="The region's lower corner (x, y)")
        high: tuple[float, float] = Property(doc="The region's upper corner (x, y)")

        def check_for_deletion(self, track: Any, **kwargs: Any) -> bool:
            if isinstance(track.state, Update):
                return False
            x = np.asarray(track.state.state_vector[[0, 2], 0], dtype=np.float64).ravel()
            return bool(np.any(x < self.low) or np.any(x > self.high))

    return OutsideRegionDeleter(tuple(low), tuple(high))


def stonesoup_tracker(
    kind: str,
    min_points: int,
    spec: Any,
    q: float,
    p_gate: float,
    prior: tuple[np.ndarray, np.ndarray],
    region: bool = False,
) -> tuple[Any, dict[str, Any]]:
    """Stone Soup's ``kind`` (``"GNN"`` or ``"JPDA"``) tracker with ``MultiMeasurementInitiator``
    (``min_points``) for the sensor ``spec``, and its settings in words.

    The state is Stone Soup's ``[x, vx, y, vy]``; ``q`` the white-noise acceleration intensity
    (m²/s³) of each axis; ``prior`` the new tracks' velocity mean (2,) and covariance (2, 2);
    ``region``: tracks (and holding tracks) are also deleted as ours are when they coast out of the
    observed region.
    """
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.dataassociator.probability import JPDAwithEHM
    from stonesoup.deleter.multi import CompositeDeleter
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    from agents.jpda.associator import MIN_CLUTTER_RATE
    from agents.tracking.assign import chi2_gate
    from predictors.kalman.predictor import R_FLOOR

    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    r = max(spec.noise_std**2, R_FLOOR)
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2) * r)
    predictor = KalmanPredictor(transition)
    updater = KalmanUpdater(measurement)
    gate = math.sqrt(chi2_gate(p_gate, 2))
    gnn = GNNWith2DAssignment(
        DistanceHypothesiser(predictor, updater, measure=Mahalanobis(), missed_distance=gate)
    )

    def deleter() -> Any:
        misses = UpdateTimeStepsDeleter(DELETE_AFTER_MISSES)
        if not region:
            return misses
        return CompositeDeleter([misses, region_deleter(spec.region_low, spec.region_high)], intersect=False)

    v_mean, v_cov = prior
    prior_mean = np.array([[0.0], [v_mean[0]], [0.0], [v_mean[1]]])
    prior_cov = np.zeros((4, 4))
    prior_cov[np.ix_([1, 3], [1, 3])] = v_cov
    initiator = MultiMeasurementInitiator(
        prior_state=GaussianState(prior_mean, prior_cov),
        deleter=deleter(),
        data_associator=gnn,
        updater=updater,
        measurement_model=measurement,
        min_points=min_points,
    )
    area = float(np.prod(np.subtract(spec.region_high, spec.region_low)))
    clutter_density = max(spec.clutter_rate, MIN_CLUTTER_RATE) / area
    settings: dict[str, Any] = {
        "transition": f"ConstantVelocity(noise_diff_coeff={q:g}) per axis, dt {spec.dt:g} s",
        "measurement": f"LinearGaussian(mapping=(0, 2), noise_covar={r:.3g} I)",
        "initiator": f"MultiMeasurementInitiator(min_points={min_points}), holding tracks by the GNN below",
        "prior velocity": f"mean ({v_mean[0]:.4f}, {v_mean[1]:.4f}) m/s, std "
        f"({math.sqrt(v_cov[0, 0]):.4f}, {math.sqrt(v_cov[1, 1]):.4f}) m/s",
        "deleter": f"UpdateTimeStepsDeleter(time_steps_since_update={DELETE_AFTER_MISSES})"
        + (
            " or OutsideRegionDeleter (coasting out of the window), CompositeDeleter(intersect=False)"
            if region
            else ""
        ),
        "gnn": f"GNNWith2DAssignment(DistanceHypothesiser(Mahalanobis, missed_distance={gate:.4f}))",
    }
    if kind == "GNN":
        tracker = MultiTargetTracker(
            initiator=initiator,
            deleter=deleter(),
            detector=None,
            data_associator=gnn,
            updater=updater,
        )
        settings["tracker"] = "MultiTargetTracker"
    elif kind == "JPDA":
        pda = PDAHypothesiser(
            predictor,
            updater,
            clutter_spatial_density=clutter_density,
            prob_detect=spec.p_detect,
            prob_gate=p_gate,
        )
        tracker = MultiTargetMixtureTracker(
            initiator=initiator,
            deleter=deleter(),
            detector=None,
            data_associator=JPDAwithEHM(pda),
            updater=updater,
        )
        settings["tracker"] = (
            f"MultiTargetMixtureTracker, JPDAwithEHM(PDAHypothesiser(prob_detect={spec.p_detect:g}, "
            f"prob_gate={p_gate:g}, clutter_spatial_density={clutter_density:.4g} /m²))"
        )
    else:
        raise ValueError(f"kind must be 'GNN' or 'JPDA', got {kind!r}")
    return tracker, settings


def run_stonesoup(tracker: Any, stream: Any) -> tuple[list[Frame], list[Frame], float]:
    """``tracker`` over ``stream``'s detections: the online frames (the tracks it holds after each
    frame), the history frames (online plus the held states of each track before its
    confirmation) and the mean ms per frame of ``update_tracker``."""
    from stonesoup.types.detection import Detection

    start = datetime.datetime(2000, 1, 1)
    dt = datetime.timedelta(seconds=stream.spec.dt)
    model = tracker.updater.measurement_model
    ids: dict[str, int] = {}
    first_seen: dict[int, int] = {}
    confirmed: dict[int, Any] = {}
    online: list[list[tuple[int, np.ndarray]]] = []
    spent = 0.0
    for t, obs in enumerate(stream.observations):
        stamp = start + t * dt
        z = obs["detections"][obs["mask"].astype(bool)].astype(np.float64)
        detections = {Detection(row.reshape(2, 1), timestamp=stamp, measurement_model=model) for row in z}
        t0 = time.perf_counter()
        _, tracks = tracker.update_tracker(stamp, detections)
        spent += time.perf_counter() - t0
        rows = []
        for track in tracks:
            i = ids.setdefault(track.id, len(ids))
            if i not in first_seen:
                first_seen[i], confirmed[i] = t, track
            rows.append((i, np.array(track.state_vector[[0, 2], 0], dtype=np.float64).ravel()))
        online.append(rows)
    history = [list(rows) for rows in online]
    for i, track in confirmed.items():
        for state in track.states:
            t = round((state.timestamp - start) / dt)
            if t < first_seen[i]:
                history[t].append((i, np.array(state.state_vector[[0, 2], 0], dtype=np.float64).ravel()))
    return _as_frames(online), _as_frames(history), 1e3 * spent / len(stream.observations)


def _as_frames(rows: list[list[tuple[int, np.ndarray]]]) -> list[Frame]:
    return [
        (
            np.array([i for i, _ in r], dtype=np.int64),
            np.array([p for _, p in r], dtype=np.float64).reshape(len(r), 2),
        )
        for r in rows
    ]


def run_condition(
    n_targets: int,
    p_detect: float,
    clutter: float,
    frames: int,
    seed: int,
    peers: Sequence[str],
    region: bool,
    log: Callable[[str], None],
) -> list[dict[str, Any]]:
    """Every row of one sensor setting and seed."""
    stream = make_stream(n_targets, p_detect, clutter, frames, seed)
    base = {"p_detect": p_detect, "clutter": stream.spec.clutter_rate, "seed": seed}
    records: list[dict[str, Any]] = []
    ours_ms: dict[str, float] = {}
    gnn_agent = None
    for label, name in OURS:
        got, updated, ms, agent = run_ours(name, stream)
        ours_ms[label] = ms
        if name == "gnn":
            gnn_agent = agent
        records.append({**base, "row": f"{label}", "family": label, "ms": ms, **score(stream, got)})
        for k in MIN_POINTS:
            records.append(
                {
                    **base,
                    "row": f"{label} post-hoc >= {k}",
                    "family": label,
                    "ms": ms,
                    **score(stream, post_hoc(got, updated, k)),
                }
            )
    if peers:
        assert gnn_agent is not None
        prior = velocity_prior(gnn_agent)
        q = float(gnn_agent.predictor.q)
        for kind in peers:
            for k in MIN_POINTS:
                tracker, settings = stonesoup_tracker(
                    kind, k, stream.spec, q, float(gnn_agent.p_gate), prior, region
                )
                if seed == 0:
                    log(
                        f"  Stone Soup {kind} min_points={k}: "
                        + "; ".join(f"{a}: {b}" for a, b in settings.items())
                    )
                online, history, ms = run_stonesoup(tracker, stream)
                family = kind.lower()
                for how, got in (("online", online), ("history", history)):
                    records.append(
                        {
                            **base,
                            "row": f"Stone Soup {kind}{' +region' if region else ''} min_points={k} ({how})",
                            "family": family,
                            "ms": ms,
                            **score(stream, got),
                        }
                    )
    for r in records:
        r["x_ours"] = r["ms"] / ours_ms[r["family"]]
        log(
            f"  p_D {p_detect:g} clutter {r['clutter']:g} seed {seed} {r['row']:40s} MOTA {r['mota']:7.3f} "
            f"IDF1 {r['idf1']:.3f} HOTA {r['hota']:.3f} ids/targets {r['ids_per_target']:6.2f} "
            f"{r['ms']:8.2f} ms/frame"
        )
    return records


def table(records: list[dict[str, Any]]) -> str:
    """The markdown table: every row's mean over the seeds with the seeds' range."""

    def cell(values: list[float], fmt: str) -> str:
        a = np.asarray(values)
        if len(a) == 1:
            return format(a[0], fmt)
        return f"{format(a.mean(), fmt)} [{format(a.min(), fmt)}, {format(a.max(), fmt)}]"

    lines = [
        "| p_D | clutter / frame | row | MOTA | IDF1 | HOTA | ids / targets | ms / frame | x ours |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    keys = list(dict.fromkeys((r["p_detect"], r["clutter"], r["row"]) for r in records))
    for p, c, row in keys:
        mine = [r for r in records if (r["p_detect"], r["clutter"], r["row"]) == (p, c, row)]
        figures = [
            cell([r[k] for r in mine], f)
            for k, f in (("mota", ".3f"), ("idf1", ".3f"), ("hota", ".3f"), ("ids_per_target", ".2f"))
        ]
        ms = cell([r["ms"] for r in mine], ".2f")
        ratio = f"{np.mean([r['x_ours'] for r in mine]):.1f}x"
        lines.append(f"| {p:g} | {c:g} | {row} | {' | '.join(figures)} | {ms} | {ratio} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--targets", type=int, default=20, help="targets in view (default 20)")
    parser.add_argument("--frames", type=int, default=300, help="frames per stream (default 300)")
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="stream seeds (default 0 1 2)"
    )
    parser.add_argument(
        "--peers",
        choices=("stonesoup", "none"),
        default="stonesoup",
        help="run Stone Soup alongside (default; skipped when it is not installed) or none",
    )
    parser.add_argument(
        "--stonesoup",
        nargs="+",
        choices=("GNN", "JPDA"),
        default=["GNN", "JPDA"],
        help="Stone Soup's trackers to run (default GNN JPDA)",
    )
    parser.add_argument(
        "--region-deleter",
        action="store_true",
        help="Stone Soup also deletes a track that coasts out of the window, as ours do "
        "(default: the 3-miss deleter alone)",
    )
    parser.add_argument("--out", type=Path, default=Path("results/existence"))
    args = parser.parse_args()
    if args.targets < 1 or args.frames < 1:
        parser.error(f"--targets and --frames must be >= 1, got {args.targets} and {args.frames}")
    from threadpoolctl import threadpool_limits

    import agents  # noqa: F401  (every BLAS is loaded before the one-thread limit)

    version = stonesoup_version() if args.peers == "stonesoup" else None
    peers = list(args.stonesoup) if version is not None else []
    if args.peers == "stonesoup" and version is None:
        print("Stone Soup is not installed (pip install -e .[compare]): the project's rows only")
    records: list[dict[str, Any]] = []
    with threadpool_limits(limits=1):
        print(machine_note(), flush=True)
        if version is not None:
            print(f"Stone Soup {version}", flush=True)
        print(
            f"{args.targets} targets in view, {args.frames} frames, seeds {args.seeds}, match distance "
            f"{THRESHOLD * 1e3:g} mm",
            flush=True,
        )
        for p_detect, clutter in CONDITIONS:
            for seed in args.seeds:
                records += run_condition(
                    args.targets,
                    p_detect,
                    clutter,
                    args.frames,
                    seed,
                    peers,
                    args.region_deleter,
                    lambda s: print(s, flush=True),
                )
        print(machine_note(), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "existence.json", json.dumps(records, indent=1))
    print(table(records))
    print(f"records: {args.out / 'existence.json'}")


if __name__ == "__main__":
    main()
