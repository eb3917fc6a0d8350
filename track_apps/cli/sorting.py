"""``track run``'s sorting flags: predicted crossings of a nozzle bar, and their truth-free check.

``--sorting-line X``
    The tracker is told of a sorting line (the nozzle bar) at ``x = X``, downstream of the
    camera window (the region's ``x_high``), and predicts each track's crossing of it when it
    lets the track go (the gnn agent). The predictions go to a CSV
    ([`track_envs.io.crossings`][track_envs.io.crossings]: ``id,frame,t_cross,y_cross,var_t,cov_ty,var_y``),
    by default ``OUT.sorting.csv`` beside ``--out`` (``OUT`` its path without suffix). Tracks still
    alive at the recording's end get none.
``--sorting-check line=L,cut=C[,lateral_tolerance=W,time_tolerance=T,min_seen=N]``
    The truth-free check of [`agents.sorting.check`][agents.sorting.check] (NAME=VALUE grammar): a virtual
    line ``x = L`` inside the camera window, predictions from the detections at ``x <= C`` (``C < L``),
    scored against where the tracks of ``--out`` crossed ``L``. Prints the figures (hit rate,
    error percentiles) and writes the scored predictions, by default to
    ``OUT.sorting-check.csv`` (the prediction columns, then ``track,x_seen,t_true,y_true``).
``--sorting-out PATH``
    Where either of them writes instead (with only one of the two flags).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from track_apps.cli import arguments
from track_envs.io.crossings import PredictedCrossings, write_crossings
from track_envs.metrics.crossing_check import LATERAL_TOLERANCE, MIN_SEEN, TIME_TOLERANCE
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks
from track_envs.values.types import SensorSpec

#: The names ``--sorting-check`` takes, and their defaults (None: required).
CHECK_NAMES: dict[str, float | int | None] = {
    "line": None,
    "cut": None,
    "lateral_tolerance": LATERAL_TOLERANCE,
    "time_tolerance": TIME_TOLERANCE,
    "min_seen": MIN_SEEN,
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the sorting flags (module docstring) as their own group."""
    g = parser.add_argument_group("sorting predictions (the nozzle bar)")
    g.add_argument(
        "--sorting-line",
        type=float,
        metavar="X",
        help="predict each track's crossing of the line x = X downstream of the camera window and write "
        "them (default file OUT.sorting.csv)",
    )
    g.add_argument(
        "--sorting-check",
        type=arguments.kwargs_type("--sorting-check"),
        metavar="line=L,cut=C,...",
        help="truth-free check: predictions of the virtual line x = L made from the detections at x <= C, "
        "scored against the tracks' own crossings of L; also lateral_tolerance= (detection units, default "
        f"{LATERAL_TOLERANCE:g}), time_tolerance= (s, default {TIME_TOLERANCE:g}), min_seen= (default "
        f"{MIN_SEEN}) (default file OUT.sorting-check.csv)",
    )
    g.add_argument(
        "--sorting-out", metavar="PATH", help="the file --sorting-line or --sorting-check writes instead"
    )


def check_arguments(args: argparse.Namespace, spec: SensorSpec) -> dict[str, Any] | None:
    """Check the sorting flags against the sensor spec before tracking; return the check's
    arguments (defaults filled in), or None without ``--sorting-check``.

    Raises:
        ValueError: naming the flag, the value and what it must be.
    """
    from agents.sorting.check import check_line_and_cut
    from track_envs.metrics.crossing_check import check_tolerances

    if args.sorting_out is not None and (args.sorting_line is None) == (args.sorting_check is None):
        raise ValueError(
            "--sorting-out needs exactly one of --sorting-line and --sorting-check (each writes its own file)"
        )
    if args.sorting_line is not None:
        x_high = spec.region_high[0]
        if not (np.isfinite(args.sorting_line) and args.sorting_line > x_high):
            raise ValueError(
                f"--sorting-line {args.sorting_line:g} must lie downstream of the camera window, past its "
                f"x_high = {x_high:.6g} (the region's; for a line inside the window use --sorting-check)"
            )
    if args.sorting_check is None:
        return None
    given = dict(args.sorting_check)
    unknown = sorted(set(given) - set(CHECK_NAMES))
    if unknown:
        raise ValueError(f"--sorting-check: unknown name(s) {unknown}; valid names are {list(CHECK_NAMES)}")
    missing = [name for name, default in CHECK_NAMES.items() if default is None and name not in given]
    if missing:
        raise ValueError(f"--sorting-check needs {' and '.join(missing)} (e.g. line=0.35,cut=0.3)")
    check: dict[str, Any] = {name: given.get(name, default) for name, default in CHECK_NAMES.items()}
    try:
        check["line"], check["cut"] = check_line_and_cut(spec, check["line"], check["cut"])
        check_tolerances(check["lateral_tolerance"], check["time_tolerance"], check["min_seen"])
    except ValueError as exc:
        raise ValueError(f"--sorting-check: {str(exc).removeprefix('sorting check: ')}") from None
    return check


def output_paths(args: argparse.Namespace) -> list[Path]:
    """The files the sorting flags will write (checked for writing before anything is read)."""
    paths = []
    if args.sorting_line is not None:
        paths.append(Path(args.sorting_out) if args.sorting_out else sidecar(args.out, ".sorting.csv"))
    if args.sorting_check is not None:
        paths.append(Path(args.sorting_out) if args.sorting_out else sidecar(args.out, ".sorting-check.csv"))
    return paths


def sidecar(out: str, suffix: str) -> Path:
    """``OUT`` without its suffix, plus ``suffix`` (``tracks.txt`` → ``tracks.sorting.csv``)."""
    path = Path(out)
    return path.with_name(path.stem + suffix)


def write_predictions(args: argparse.Namespace, crossings: PredictedCrossings, tracks: Tracks) -> None:
    """Write ``--sorting-line``'s predictions and print a line about them (stderr)."""
    path = Path(args.sorting_out) if args.sorting_out else sidecar(args.out, ".sorting.csv")
    write_crossings(path, crossings)
    n_ids = len(np.unique(tracks.ids))
    std = np.sqrt(np.median(crossings.cov[:, [0, 1], [0, 1]], axis=0)) if len(crossings) else [np.nan] * 2
    print(
        f"{args.prog}: {len(crossings)} predicted crossings of x = {crossings.line:g} for {n_ids} track ids "
        f"(median std {1000 * std[0]:.3g} ms, {std[1]:.3g} across) -> {path}",
        file=sys.stderr,
    )


def run_check(
    args: argparse.Namespace,
    check: dict[str, Any],
    agent: Any,
    detections: Detections,
    spec: SensorSpec,
    tracks: Tracks,
) -> None:
    """Run ``--sorting-check`` with the tracks of ``--out`` as the reference; print the figures
    (stdout) and write the scored predictions."""
    from agents.sorting.check import check_sorting

    result = check_sorting(agent, detections, spec, reference=tracks, seed=args.seed, **check)
    path = Path(args.sorting_out) if args.sorting_out else sidecar(args.out, ".sorting-check.csv")
    write_crossings(path, result.predictions)
    print(format_check(result.score.summary(spec.units), check, spec.units))
    print(f"{args.prog}: scored predictions -> {path}", file=sys.stderr)


def format_check(summary: dict[str, float], check: dict[str, Any], units: str) -> str:
    """The check's figures as a two-column table, headed by the line, cut-off and tolerances."""
    head = (
        f"sorting check: line x = {check['line']:g}, predicted from x <= {check['cut']:g}; hit: "
        f"|dt| <= {1000 * check['time_tolerance']:g} ms and |dy| <= {check['lateral_tolerance']:g} {units}"
    )
    width = max(map(len, summary))
    rows = [head, f"{'figure':<{width}}  value", f"{'-' * width}  {'-' * 12}"]
    rows += [f"{k:<{width}}  {v:.6g}" for k, v in summary.items()]
    return "\n".join(rows)
