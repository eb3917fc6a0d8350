"""``track run`` on pose files (COCO keypoint results, PoseTrack JSON:
[`track_envs.io.poses`][track_envs.io.poses]).

The file is read into a [`PoseStream`][track_envs.PoseStream], tracked with a pose agent
([`agents.files.poses.run_pose_agent`][agents.run_pose_agent]), written as PoseTrack results and, with
``--gt`` and ``--metrics``, scored with per-joint MOTA and HOTA
([`track_envs.metrics.pose_scoring.score_poses`][track_envs.metrics.score_poses]). Which agents run on which
kind of file:
[`agents.files.kinds`][agents.files.kinds].

Everything that can stop a run is checked before tracking: ``--out`` can be written, the pose
file and the ground truth read whole (with ``--metrics`` every ground-truth pose needs its
``track_id`` and ``bbox_head``: [`track_envs.io.poses.read_pose_file`][track_envs.io.read_pose_file]), their
keypoints agree. ``pose-baseline`` sizes its OKS gate (``area_factor``) from how far the file's poses move
a frame ([`agents.pose.gate`][agents.pose.gate]; ``--agent-kwargs area_factor=A`` sets it), printed; a run
whose ids look wrong (most poses start a track, most tracks 1-2 frames long) is warned about
([`track_apps.cli.pose_diagnostics`][track_apps.cli.pose_diagnostics]). The results file is written
atomically.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from typing import Any

from agents.base import warm_up
from agents.files.kinds import FILE_KINDS, check_file_agent, file_agents


def agent_help() -> str:
    """The ``--agent`` help: the agents for each kind of file."""
    kinds = "; ".join(f"{kind} files: {', '.join(file_agents(kind))}" for kind in FILE_KINDS)
    return f"default gnn for point files, pose-baseline for pose files ({kinds})"


def add_pose_arguments(p: argparse.ArgumentParser) -> None:
    """The options of pose files."""
    g = p.add_argument_group("pose files (COCO keypoint results, PoseTrack JSON)")
    g.add_argument(
        "--frames",
        help="COCO: the frame order, a JSON with 'images' (PoseTrack / COCO annotations; default: --gt's "
        "images, else sorted image ids) or a text file of image ids",
    )
    g.add_argument("--pckh", type=float, default=0.5, help="per-joint MOTA match radius in head sizes (0.5)")


def run_poses(args: argparse.Namespace) -> int:
    """Read a pose file, track it with a pose agent, write PoseTrack results, score against --gt."""
    from agents.files.poses import run_pose_agent
    from track_apps.cli.pose_diagnostics import pose_run_warnings
    from track_apps.cli.run_shared import build_agent, format_metrics
    from track_envs.infra.atomic import check_writable
    from track_envs.io.poses import write_posetrack
    from track_envs.metrics.pose_scoring import score_poses
    from track_envs.values.poses import pose_sensor_spec

    name = args.agent or "pose-baseline"
    check_file_agent(name, "pose")
    _reject_point_options(args)
    if args.metrics and not args.gt:
        raise ValueError("--metrics needs --gt GT (the PoseTrack ground-truth file)")
    check_writable(args.out)
    start = time.perf_counter()
    fmt, stream, truth = _read_inputs(args)
    spec = pose_sensor_spec(
        stream,
        fps=1.0 / args.dt if args.dt else 30.0,
        max_detections=args.max_detections,
        max_tracks=args.max_tracks,
    )
    agent = build_agent(name, args.predictor, _agent_kwargs(args, name, stream))
    warm_up(agent)
    read_s = time.perf_counter() - start
    tracks = run_pose_agent(agent, stream, spec, seed=args.seed)
    if truth is not None and tracks.keypoint_names != truth.keypoint_names:
        tracks = tracks.with_rows(keypoint_names=truth.keypoint_names)  # poseval reads the names
    write_posetrack(args.out, tracks)
    print(
        f"{args.prog}: {stream.n_frames} frames, {len(stream)} poses ({fmt}, read in {read_s:.2f} s) -> "
        f"{len(tracks)} tracked poses, {len(set(tracks.track_ids.tolist()))} tracks -> {args.out} "
        "(posetrack)",
        file=sys.stderr,
    )
    for problem in pose_run_warnings(tracks, stream):
        print(f"{args.prog}: warning: {problem}", file=sys.stderr)
    if truth is not None and args.metrics:
        metrics, notes = score_poses(tracks, truth, pckh=args.pckh)
        print(format_metrics(metrics))
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
    return 0


def _read_inputs(args: argparse.Namespace) -> tuple[str, Any, Any]:
    """The format, the detections and the ground truth (or None), read whole and checked: the
    ground truth completely where ``--metrics`` scores against it; the keypoints of both agree
    with what the pose agents track. The readers' warnings are printed."""
    from track_envs.io.poses import (
        PoseFileError,
        PoseFileWarning,
        image_list,
        json_pose_format,
        load_json,
        read_pose_file,
    )
    from track_envs.metrics.keypoints import NUM_KEYPOINTS

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PoseFileWarning)
        fmt = (
            args.input_format
            if args.input_format != "auto"
            else json_pose_format(load_json(args.detections), args.detections)
        )
        frames: list[int] | None = None
        names: list[str] | None = None
        if fmt == "coco" and (args.frames or args.gt):
            frames, names = image_list(args.frames or args.gt)
        stream = read_pose_file(args.detections, fmt, frames=frames, file_names=names)
        truth = read_pose_file(args.gt, "posetrack", ground_truth=args.metrics) if args.gt else None
    for w in caught:
        kind = "warning" if issubclass(w.category, PoseFileWarning) else "note"
        print(f"{args.prog}: {kind}: {w.message}", file=sys.stderr)
    if stream.num_keypoints != NUM_KEYPOINTS:
        raise PoseFileError(
            f"{args.detections}: its poses have {stream.num_keypoints} keypoints; the pose agents track "
            f"the {NUM_KEYPOINTS} COCO keypoints"
        )
    if truth is not None and truth.num_keypoints != stream.num_keypoints:
        raise PoseFileError(
            f"{args.gt}: the ground truth's poses have {truth.num_keypoints} keypoints, those of "
            f"{args.detections} {stream.num_keypoints}"
        )
    return fmt, stream, truth


def _agent_kwargs(args: argparse.Namespace, name: str, stream: Any) -> dict[str, Any]:
    """``--agent-kwargs``, with pose-baseline's ``area_factor`` sized from the data
    ([`agents.pose.gate`][agents.pose.gate]) unless given; the gate printed."""
    from agents.pose.gate import DEFAULT_AREA_FACTOR, pose_gate

    kwargs = dict(args.agent_kwargs)
    if name != "pose-baseline" or "area_factor" in kwargs:
        return kwargs
    threshold = kwargs.get("oks_threshold")
    gate = pose_gate(stream) if threshold is None else pose_gate(stream, oks_threshold=float(threshold))
    print(f"{args.prog}: gate: {gate.describe()}", file=sys.stderr)
    if gate.area_factor != DEFAULT_AREA_FACTOR:
        kwargs["area_factor"] = gate.area_factor
    return kwargs


def _reject_point_options(args: argparse.Namespace) -> None:
    given: dict[str, Any] = {
        "--format": args.format,
        "--covariance": args.covariance or None,
        "--region": args.region,
        "--swap-xy": args.swap_xy or None,
        "--sorting-line": getattr(args, "sorting_line", None),
        "--sorting-check": getattr(args, "sorting_check", None),
        "--sorting-out": getattr(args, "sorting_out", None),
    }
    bad = [flag for flag, value in given.items() if value is not None]
    if args.scale != 1.0:
        bad.append("--scale")
    if bad:
        raise ValueError(
            f"{', '.join(bad)}: not for pose files (they are read in pixels and written as PoseTrack JSON; "
            "sorting predictions are for point tracks)"
        )
