"""What a run that estimates its sensor model prints and writes: the estimates in the input's units, the run's
figures and warnings, as text lines and as a JSON sidecar next to the track file (written
atomically: a failed write leaves the old sidecar or none,
[`track_envs.infra.atomic`][track_envs.infra.atomic])."""

from __future__ import annotations

import json
import os
from typing import Any

from agents.sensor_model.estimate import SensorModelEstimate
from track_envs.infra.atomic import write_text

#: Suffix of the sidecar: ``tracks.txt`` → ``tracks.txt.calibration.json``.
SIDECAR_SUFFIX = ".calibration.json"

_Q_UNITS = {"cv": "units²/s³", "ca": "units²/s⁵", "random-walk": "units²/s"}


def _vector(values: tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"


def summary_lines(cal: SensorModelEstimate) -> list[str]:
    """The estimates, one per line, each with its unit ("input units": positions as given) and
    whether it was estimated or given."""
    src = cal.sources
    dim = len(cal.flow)
    area_unit = "²" if dim == 2 else f"^{dim}"

    def tag(name: str) -> str:
        return "given" if src.get(name) == "given" else "estimated"

    state = "settled" if cal.settled else "not settled"
    runs = f"{cal.iterations} tracking run{'s' if cal.iterations != 1 else ''}"
    lines = [
        f"sensor model estimate ({runs}, {state}; model {cal.model}, dt {cal.dt:g} s; "
        f"from {cal.n_tracks} confident tracks):",
        f"  measurement noise std {cal.noise_std:.4g} (input units, {tag('noise_std')})",
        f"  process noise q {cal.q:.4g} ({_Q_UNITS[cal.model].replace('units', 'input units')}, {tag('q')})",
    ]
    if cal.model != "random-walk":
        lines.append(
            f"  velocity prior mean {_vector(cal.velocity_mean)} std {cal.velocity_std:.4g} "
            f"(input units/s, {tag('velocity_mean')})"
        )
    if cal.model == "ca":
        lines.append(
            f"  acceleration prior std {cal.acceleration_std:.4g} (input units/s², {tag('acceleration_std')})"
        )
    lines += [
        f"  gate p {cal.p_gate:g}: radius {cal.gate_radius:.4g} (input units, steady state)",
        f"  coasting: max_misses {cal.max_misses} ({tag('max_misses')}; "
        f"{100 * cal.reappearing:.0f}% of track ends re-appear)",
        f"  detection probability p_D {cal.p_detect:.4g} ({tag('p_detect')}"
        + (f"; from {cal.n_gaps} gaps of the confident tracks)" if tag("p_detect") == "estimated" else ")"),
        f"  clutter density {cal.clutter_density:.4g} per input unit{area_unit} and frame "
        f"({tag('clutter_density')}"
        + (
            f"; {cal.n_unclaimed} detections no track of 3 claims, over {cal.clutter_area:.4g} input "
            f"unit{area_unit})"
            if tag("clutter_density") == "estimated"
            else ")"
        ),
        "  merge extent (jpda) "
        + (
            f"{cal.merge_extent:.4g} (input units, {tag('merge_extent')}"
            + (f": {cal.merge_rule})" if tag("merge_extent") == "estimated" else ")")
            if cal.merge_extent is not None
            else "none: no boxes and no two confident tracks seen together (jpda's merge model off)"
        ),
        f"  data: nearest-neighbour distance {cal.length:.4g}, flow {_vector(cal.flow)} per frame "
        "(input units)",
    ]
    if cal.n_tracks == 0:
        lines.append(
            "  no track held enough detections to estimate from: these are the first settings from "
            "the data's spacing and flow, not estimates"
        )
    return lines


def sidecar_path(out: str | os.PathLike[str]) -> str:
    """The sidecar of a track file: its path plus
    [`SIDECAR_SUFFIX`][track_apps.cli.sensor_model_summary.SIDECAR_SUFFIX]."""
    return os.fspath(out) + SIDECAR_SUFFIX


def write_sidecar(out: str | os.PathLike[str], content: dict[str, Any]) -> str:
    """Write ``content`` as JSON next to the track file ``out``, atomically; its path.

    Raises:
        track_envs.infra.atomic.FileWriteError: naming the sidecar and the cause (an ``OSError``).
    """
    path = sidecar_path(out)
    write_text(path, json.dumps(content, indent=2, sort_keys=True) + "\n")
    return path
