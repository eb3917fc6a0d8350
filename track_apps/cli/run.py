"""``track run``: any agent over a detection file, tracks out, metrics with truth."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import re
import sys
import time
import warnings
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

from agents import available_agents
from agents.base import agent_takes_predictor, warm_up
from agents.files.kinds import check_file_agent
from agents.files.points import run_agent
from predictors import available_predictors
from track_apps.cli import arguments, run_pose, sensor_model, sorting
from track_apps.cli.run_shared import build_agent, format_metrics

if TYPE_CHECKING:
    from track_envs.values.detections import Detections
    from track_envs.values.tracks import Tracks
    from track_envs.values.types import SensorSpec

PROG = "track run"

EPILOG = """\
examples:
  track run det.txt --agent gnn --predictor kf-ca --dt 0.04 --out tracks.txt
  track run sorter.csv --swap-xy --scale 1e-4 --dt 0.005 --declared-noise-std 1e-4 --out tracks.csv \\
      --format wide
  track run sorter.csv --time-column time --out tracks.csv --format long --covariance
  track run det.txt --dt 0.005 --out tracks.txt --gt gt.txt --metrics --threshold 0.005
  track run test.txt --dt 0.04 --declared-noise-std 5 --out tracks.txt --gt gt.txt --metrics --match iou
  track run det.txt --agent gnn --agent-kwargs p_gate=0.99,max_misses=3 --seed 1 --out tracks.txt
  track run sorter.csv --time-column time --out tracks.csv --sorting-line 0.45
  track run sorter.csv --time-column time --out tracks.csv --sorting-check line=0.35,cut=0.3

Inputs: a MOTChallenge det.txt (frame, id, bb_left, bb_top, bb_width, bb_height, conf, ...; the
tracker follows the boxes' centres and each output row carries its detection's box; a confidence
of -1 means "not given" and --min-confidence keeps it) or a wide per-frame CSV (optional header;
frame column, count column, optionally a time column, then x, y pairs padded with NaN).
--input-format auto reads .txt as MOT and anything else as wide. Column options take an index
(from 0) or a header name; error messages name columns by the same index. Every problem in an
input (--gt included, read in full before tracking) stops the run with one message naming the file,
the row (its line number) and the value: a row with a missing or extra column (or cut off), text,
an infinity, a coordinate no sensor gives (beyond 1e12 times the data's spread), a file that is not
text. Detections that repeat an earlier one of their frame exactly are tracked once, and rows out
of frame order are sorted; both are warned about with their count.
Outputs (--format; by default from --out's suffix: .txt mot, .csv long, .zip wide, so that the
file reads back as --gt in the layout it was written in; a format the suffix contradicts is an
error): mot (MOTChallenge rows, frames from 1, each row the box of the detection the track was
updated with, the last one while it coasts, or a --box-size box about a point:
py-motmetrics and TrackEval read it), wide (one row per frame, one x, y pair per track id:
BeltReplay-v0 reads it back) or long (frame,id,x,y[,var_x,cov_xy,var_y],detection
[,bb_left,bb_top,bb_width,bb_height] with a header).
The sensor spec the tracker is told: --dt (or inferred from --time-column), --declared-noise-std
(the measurement noise std, in the detections' units after --scale: the tracker's R; nothing is
added to the detections), --region (or the detections' bounding box), --max-detections /
--max-tracks (or from the fullest frame; a report too small for the live tracks is grown, never an
error).
The sensor model estimate (--sensor-model auto, the default, when --declared-noise-std is not
given): the measurement noise, the Kalman process noise q, the velocity prior, how long a track
coasts, the detection probability, the clutter density and jpda's merge extent are estimated from
the detections, in their own units (pixels or metres alike), printed and written to
OUT.calibration.json; --declared-noise-std, --process-noise, --initial-velocity,
--initial-velocity-std, --p-detect, --clutter-rate / --clutter-density, --merge-extent and
max_misses in --agent-kwargs override their estimates. A run that looks
wrong (most detections start a track, most tracks 1-2 frames long) is warned about.
With --gt and --metrics, the point envs' metrics table: MOTA, IDF1, ID switches, GOSPA (match
distance and cut-off --threshold, default half the median nearest-neighbour distance within a
frame), HOTA, DetA, AssA, LocA, DetRe, DetPr, AssRe, AssPr (similarity
max(0, 1 - d / threshold)), and e1 / e2 when the detection file carries truth ids. --match
auto (default) matches boxes by IoU >= --min-iou (0.5, as MOTChallenge) when the tracks and the
ground truth both have boxes, else centres within --threshold; the line "matching: ..." says which.
Large files: the detections are read, and the tracks written, a chunk of rows at a time; the
frames are tracked one block at a time (one frame at 10^5 detections a frame), with a progress
bar on stderr when it is a terminal (--no-progress hides it).
Sorting: --sorting-line X writes each track's predicted crossing of the nozzle bar x = X (past the
camera window) to OUT.sorting.csv; --sorting-check line=L,cut=C checks such predictions without
truth: a virtual line L inside the window, predicted from the detections at x <= C, scored
against where the tracks crossed L (hit rate, error percentiles; OUT.sorting-check.csv).
"""


def _region(text: str) -> tuple[tuple[float, float], tuple[float, float]]:
    try:
        x0, y0, x1, y1 = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad --region {text!r}: use XLOW,YLOW,XHIGH,YHIGH") from None
    return (x0, y0), (x1, y1)


def _column(text: str) -> int | str | None:
    """A column option: an index (from 0), a header name, or none."""
    if text.lower() == "none":
        return None
    try:
        return int(text)
    except ValueError:
        return text


def _header(text: str) -> bool | str:
    values: dict[str, bool | str] = {"auto": "auto", "yes": True, "true": True, "no": False, "false": False}
    if text.lower() not in values:
        raise argparse.ArgumentTypeError(f"bad --header {text!r}: use auto, yes or no")
    return values[text.lower()]


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The argparse parser of ``track run`` (``prog``: the name it answers to)."""
    # long: one argparse declaration per option, in the order --help lists them
    p = argparse.ArgumentParser(
        prog=prog,
        description="Track a file of per-frame detections (no identities) with any agent; write the tracks.",
        epilog=EPILOG.replace(PROG + " ", prog + " "),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "detections", metavar="DETECTIONS", help="detection file (.txt MOT, .csv / .zip wide, .json poses)"
    )
    p.add_argument(
        "--input-format",
        choices=["auto", "mot", "wide", "coco", "posetrack"],
        default="auto",
        help="auto (default): .txt is MOT, .json poses (COCO results or PoseTrack, from the content), "
        "anything else wide",
    )
    g = p.add_argument_group("reading the detections")
    g.add_argument("--header", type=_header, default="auto", help="wide: auto (default), yes or no")
    g.add_argument(
        "--frame-column", type=_column, default=0, help="wide: frame-number column (default 0; none)"
    )
    g.add_argument("--count-column", type=_column, default=1, help="wide: count column (default 1; none)")
    g.add_argument(
        "--time-column", type=_column, default=None, help="wide: time column in seconds (infers dt)"
    )
    g.add_argument(
        "--xy-columns", type=_column, default=None, help="wide: first x column (default: after the others)"
    )
    g.add_argument("--delimiter", default=",", help="field separator (default ',')")
    g.add_argument(
        "--min-confidence",
        type=float,
        default=None,
        help="mot: drop detections below this confidence (-1, 'not given', is kept; dropping all "
        "is an error)",
    )
    g.add_argument(
        "--swap-xy", action="store_true", help="swap x and y (sorters often write the belt direction as y)"
    )
    g.add_argument("--scale", type=float, default=1.0, help="multiply positions (e.g. metres per pixel)")
    g = p.add_argument_group("the tracker and the sensor it is told of")
    g.add_argument("--agent", choices=available_agents(), help=run_pose.agent_help())
    g.add_argument(
        "--predictor", choices=available_predictors(), help="for agents that take one (default kf-ca)"
    )
    arguments.add_agent_kwargs(
        g, default=(), help="make_agent keyword arguments, e.g. p_gate=0.99,max_misses=3"
    )
    g.add_argument("--dt", type=float, help="frame period in seconds (default: inferred from --time-column)")
    arguments.add_declared_noise(g)
    g.set_defaults(
        declared_noise_std=None
    )  # not given: the run estimates its sensor model (--sensor-model auto)
    sensor_model.add_arguments(g)
    g.add_argument(
        "--region", type=_region, help="XLOW,YLOW,XHIGH,YHIGH (default: the detections' bounding box)"
    )
    g.add_argument("--max-detections", type=int, help="observation rows (default: the fullest frame, >= 16)")
    g.add_argument("--max-tracks", type=int, help="report rows (default: twice the fullest frame, >= 16)")
    arguments.add_seed(g, help="agent seed")
    g = p.add_argument_group("output and scoring")
    arguments.add_out(g, kind="file", help="the track file to write (in --format)", required=True)
    g.add_argument(
        "--format",
        choices=["mot", "wide", "long"],
        help="default: from --out's suffix (.txt mot, .csv long, .zip wide, any other mot; pose files: "
        "PoseTrack JSON); a format the suffix contradicts (mot in .csv) is an error",
    )
    g.add_argument(
        "--box-size",
        type=float,
        default=0.0,
        help="mot, point input: box width/height about each point (default 0; box input writes its boxes)",
    )
    g.add_argument(
        "--covariance",
        action="store_true",
        help="long: add each track's covariance (where the agent has one)",
    )
    g.add_argument("--gt", help="ground-truth tracks (.txt MOT gt, .csv / .zip wide track layout, or long)")
    g.add_argument(
        "--gt-format",
        choices=["auto", "mot", "wide", "long"],
        default="auto",
        help="auto (default): .txt is MOT, .zip wide, .csv long if it starts with frame,id else wide "
        "(any other name: long with that header, else MOT)",
    )
    g.add_argument("--metrics", action="store_true", help="score the tracks against --gt and print the table")
    g.add_argument(
        "--threshold",
        type=float,
        default=None,
        help="match distance and GOSPA cut-off (default: half the median nearest-neighbour distance "
        "within a frame of the detections, printed)",
    )
    g.add_argument(
        "--match",
        choices=["auto", "iou", "distance"],
        default="auto",
        help="how MOTA / IDF1 match tracks to truths: iou (boxes), distance (centres, --threshold) or "
        "auto (default: iou when the tracks and the ground truth have boxes)",
    )
    g.add_argument(
        "--min-iou", type=float, default=0.5, help="--match iou: smallest IoU of a match (default 0.5)"
    )
    g.add_argument(
        "--coasting-rows",
        choices=["auto", "all", "none"],
        default="auto",
        help="write the rows of tracks coasting through a frame without a detection: all, none, or auto "
        "(default: none for box input, as MOTChallenge trackers write boxes only where they saw the "
        "object; all for points)",
    )
    arguments.add_no_progress(g)
    run_pose.add_pose_arguments(p)
    sorting.add_arguments(p)
    return p


def _read_options(args: argparse.Namespace, fmt: str) -> dict[str, Any]:
    common: dict[str, Any] = {"swap_xy": args.swap_xy, "scale": args.scale, "delimiter": args.delimiter}
    if fmt == "mot":
        return common | {"min_confidence": args.min_confidence}
    return common | {
        "header": args.header,
        "frame_column": args.frame_column,
        "count_column": args.count_column,
        "time_column": args.time_column,
        "xy_columns": args.xy_columns,
    }


def run(args: argparse.Namespace) -> int:
    """Read, track, write, score (the body of [`main`][track_apps.cli.run.main])."""
    from agents.sensor_model.diagnostics import count_distinct, run_figures, run_warnings
    from track_apps.cli.sensor_model_summary import write_sidecar
    from track_envs.io.poses import is_pose_file
    from track_envs.io.tracks import write_tracks

    if is_pose_file(args.detections, args.input_format):
        return run_pose.run_poses(args)
    _check_point_arguments(args)
    start = time.perf_counter()
    detections, truth, kind, spec = _read_inputs(args)
    check = sorting.check_arguments(args, spec)
    if args.predictor is not None and not agent_takes_predictor(args.agent):
        raise ValueError(f"agent {args.agent!r} takes no predictor; drop --predictor")
    spec, agent_kwargs, estimate, estimate_s = _agent_settings(args, detections, spec)
    agent = build_agent(args.agent, args.predictor, agent_kwargs)
    warm_up(agent)  # compile / load the kernels before the first frame
    read_s = time.perf_counter() - start - estimate_s
    tracks, crossings = _track(args, agent, detections, spec)
    write_start = time.perf_counter()
    write_tracks(args.out, tracks, args.format, box_size=args.box_size)
    write_s = time.perf_counter() - write_start
    print(
        f"{args.prog}: {detections.n_frames} frames, {len(detections)} detections "
        f"(read in {read_s:.2f} s) -> "
        f"{len(tracks)} track rows, {count_distinct(tracks.ids)} ids -> {args.out} ({args.format}, "
        f"written in {write_s:.2f} s)",
        file=sys.stderr,
    )
    if crossings is not None:
        sorting.write_predictions(args, crossings, tracks)
    if check is not None:
        sorting.run_check(args, check, agent, detections, spec, tracks)
    problems = run_warnings(tracks, len(detections))
    for problem in problems:
        print(f"{args.prog}: warning: {problem}", file=sys.stderr)
    threshold = _metric_threshold(args, estimate, detections)
    if estimate is not None:
        content = {"calibration": estimate.as_dict(), "run": run_figures(tracks, len(detections))}
        content |= {"warnings": problems, "metric_threshold": threshold, "max_tracks": spec.max_tracks}
        path = write_sidecar(args.out, content)
        print(f"{args.prog}: sensor model estimate ({estimate_s:.2f} s) -> {path}", file=sys.stderr)
    if truth is not None and args.metrics:
        assert threshold is not None
        _print_metrics(args, tracks, truth, detections, kind, threshold)
    return 0


def _check_point_arguments(args: argparse.Namespace) -> None:
    """Fill the point run's defaults (``--agent gnn``, ``--format`` from ``--out``'s suffix) and
    refuse what does not fit before anything is read (the agent, ``--format`` against the suffix,
    ``--covariance``, ``--metrics``, ``--min-iou``, ``--out`` and the sorting file not writable)."""
    from track_envs.io.tracks import output_format

    args.agent = args.agent or "gnn"
    args.format = output_format(args.out, args.format)
    check_file_agent(args.agent, "point")
    if args.covariance and args.format != "long":
        raise ValueError("--covariance needs --format long (MOT and wide files hold no covariance)")
    if args.metrics and not args.gt:
        raise ValueError("--metrics needs --gt GT (the ground-truth file)")
    if not (0 < args.min_iou <= 1):
        raise ValueError(f"--min-iou must be in (0, 1], got {args.min_iou!r}")
    check_out_file(args.out)
    for path in sorting.output_paths(args):
        check_out_file(str(path), "--sorting-out" if args.sorting_out else "--out")


def _read_inputs(args: argparse.Namespace) -> tuple[Detections, Tracks | None, str, SensorSpec]:
    """The detections, the ground truth (``--gt``, read and checked before tracking, as
    ``--out``), how tracks are matched to it, and the sensor spec the flags give."""
    from track_envs.io.detections import CONSIDERED, detection_format, read_detections
    from track_envs.io.tracks import read_tracks
    from track_envs.metrics.track_scoring import match_kind
    from track_envs.values.detections import detection_sensor_spec

    fmt = detection_format(args.detections, args.input_format)
    with file_warnings(args.prog):
        detections = read_detections(args.detections, fmt, **_read_options(args, fmt))
        truth = None
        if args.gt:  # read and checked in full before anything is tracked
            truth = read_tracks(args.gt, args.gt_format, min_confidence=CONSIDERED if _is_mot(args) else None)
    kind = "distance"
    if truth is not None:
        kind = match_kind(detections.boxes is not None, truth.boxes is not None, args.match)
    with FlagNames():
        spec = detection_sensor_spec(
            detections,
            dt=args.dt,
            region=args.region,
            measurement_noise_std=0.0 if args.declared_noise_std is None else args.declared_noise_std,
            p_detect=args.p_detect,
            clutter_rate=args.clutter_rate,
            max_detections=args.max_detections,
            max_tracks=args.max_tracks,
        )
    return detections, truth, kind, spec


def _agent_settings(
    args: argparse.Namespace, detections: Detections, spec: SensorSpec
) -> tuple[SensorSpec, dict[str, Any], Any, float]:
    """The spec and agent keywords of the run: with its sensor model estimated (printed; with the
    estimate and the seconds it took) or as the flags give them."""
    from agents.sensor_model.estimate import live_track_bound
    from track_apps.cli.sensor_model_summary import summary_lines

    spec, agent_kwargs = sensor_model.declared(args, spec, dict(args.agent_kwargs))
    estimate = None
    estimate_s = 0.0
    if sensor_model.wanted(args):
        estimate_start = time.perf_counter()
        spec, agent_kwargs, estimate = sensor_model.estimated(args, detections, spec, agent_kwargs)
        estimate_s = time.perf_counter() - estimate_start
        for line in summary_lines(estimate):
            print(f"{args.prog}: {line}", file=sys.stderr)
        if args.max_tracks is None:  # a report that holds every track the run can have
            rows = live_track_bound(detections, int(agent_kwargs.get("max_misses", 2)))
            spec = dataclasses.replace(spec, max_tracks=max(spec.max_tracks, rows))
    elif sensor_model.given_kwargs(args):
        if args.agent != "gnn":
            raise ValueError(
                "--process-noise, --initial-velocity and --initial-velocity-std need --agent gnn"
            )
        agent_kwargs = sensor_model.given_kwargs(args) | agent_kwargs
    return spec, agent_kwargs, estimate, estimate_s


def _track(
    args: argparse.Namespace, agent: Any, detections: Detections, spec: SensorSpec
) -> tuple[Tracks, Any]:
    """Run ``agent`` over the detections (its warnings printed as notes); the tracks (only the
    updated rows where ``--coasting-rows`` resolves to none) and the sorting predictions or None."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        result = run_agent(
            agent,
            detections,
            spec,
            seed=args.seed,
            covariance=args.covariance,
            progress=show_progress(args),
            sorting_line=args.sorting_line,
        )
    for w in caught:
        print(f"{args.prog}: note: {w.message}", file=sys.stderr)
    tracks, crossings = result if isinstance(result, tuple) else (result, None)
    if coasting_rows(args, detections) == "none":
        tracks = tracks.updated_rows()
    return tracks, crossings


def _metric_threshold(args: argparse.Namespace, estimate: Any, detections: Detections) -> float | None:
    """``--threshold``, or with ``--metrics`` its default (the sensor model estimate's, else half the median
    nearest-neighbour distance within a frame; printed)."""
    from agents.sensor_model.scales import default_threshold

    threshold: float | None = args.threshold
    if threshold is None and args.metrics:
        threshold = estimate.threshold if estimate is not None else default_threshold(detections)
        print(
            f"{args.prog}: metric threshold {threshold:.4g} (input units: half the median nearest-neighbour "
            "distance within a frame; --threshold sets it)",
            file=sys.stderr,
        )
    return threshold


def _print_metrics(
    args: argparse.Namespace,
    tracks: Tracks,
    truth: Tracks,
    detections: Detections,
    kind: str,
    threshold: float,
) -> None:
    """Score the tracks against the truth and print the matching line and the metrics table."""
    from track_envs.metrics.track_scoring import match_line, score_tracks

    print(f"matching: {match_line(kind, threshold=threshold, min_iou=args.min_iou)}", file=sys.stderr)
    metrics, notes = score_tracks(
        tracks, truth, threshold=threshold, detections=detections, match=kind, min_iou=args.min_iou
    )
    print(format_metrics(metrics))
    for note in notes:
        print(f"note: {note}", file=sys.stderr)


#: detection_sensor_spec's argument names and the flags of ``track run`` that set them.
SPEC_FLAGS = {
    "measurement_noise_std": "--declared-noise-std",
    "max_detections": "--max-detections",
    "max_tracks": "--max-tracks",
    "clutter_rate": "--clutter-rate",
    "p_detect": "--p-detect",
    "region": "--region",
    "dt": "--dt",
}


class FlagNames:
    """A context that re-raises a ``ValueError`` whose message names an argument of
    [`detection_sensor_spec`][track_envs.detection_sensor_spec] (``measurement_noise_std must be ...``)
    naming the flag instead ([`SPEC_FLAGS`][track_apps.cli.run.SPEC_FLAGS])."""

    def __init__(self) -> None:
        self.flags = dict(SPEC_FLAGS)

    def __enter__(self) -> FlagNames:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: Any) -> bool:
        if isinstance(exc, ValueError) and "--" not in str(exc):
            names = "|".join(map(re.escape, self.flags))
            text = re.sub(rf"\b({names})\b", lambda m: self.flags[m.group(1)], str(exc))
            raise ValueError(text) from exc
        return False


@contextlib.contextmanager
def file_warnings(prog: str) -> Iterator[None]:
    """Print the readers' [`DetectionFileWarning`][track_envs.io.DetectionFileWarning] (repeated
    detections dropped, rows sorted into frame order) as ``PROG: warning: ...`` lines on stderr."""
    from track_envs.io.csv_parser import DetectionFileWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DetectionFileWarning)
        try:
            yield
        finally:
            for w in caught:
                if issubclass(w.category, DetectionFileWarning):
                    print(f"{prog}: warning: {w.message}", file=sys.stderr)
                else:
                    warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def check_out_file(path: str, flag: str = "--out") -> None:
    """Raise ``ValueError`` naming ``flag`` unless ``path`` can be written: not a directory, its
    directory exists and is writable (and an existing file is writable), and a file can be made
    there ([`track_envs.infra.atomic.check_writable`][track_envs.io.check_writable]: ``/proc/x`` cannot) —
    checked before anything is read, so that a long run does not fail at its end."""
    from track_envs.infra.atomic import check_writable

    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ValueError(
            f"{flag} {path} is a directory; give a file name (e.g. {os.path.join(path, 'tracks.txt')})"
        )
    if not os.path.isdir(folder):
        raise ValueError(f"{flag} {path}: the directory {folder} does not exist")
    if not os.access(folder, os.W_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise ValueError(f"{flag} {path} is not writable")
    try:
        check_writable(path)
    except OSError as exc:
        raise ValueError(f"{flag} {exc.strerror or exc}") from None


def show_progress(args: argparse.Namespace) -> bool:
    """Whether the run shows its progress bar: not with ``--no-progress``, and only on a terminal
    (a run whose stderr goes to a file or a pipe logs no bar)."""
    return not args.no_progress and sys.stderr.isatty()


def coasting_rows(args: argparse.Namespace, detections: Any) -> str:
    """``--coasting-rows`` resolved: ``"none"`` or ``"all"`` (``auto``: none where the detections
    carry boxes, all for points)."""
    if args.coasting_rows != "auto":
        return str(args.coasting_rows)
    return "none" if detections.boxes is not None else "all"


def _is_mot(args: argparse.Namespace) -> bool:
    from track_envs.io.tracks import track_format

    return track_format(args.gt, args.gt_format) == "mot"


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Entry point of ``track run`` (``prog``: the name it answers to)."""
    args = build_parser(prog).parse_args(argv)
    args.prog = prog
    try:
        return run(args)
    except (ValueError, OSError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
