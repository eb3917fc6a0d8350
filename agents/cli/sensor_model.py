"""The self-calibration of ``track run``: its options, and how they turn into the agent and sensor spec.

With ``--calibrate auto`` (the default) a run without ``--declared-noise-std`` calibrates itself
(:func:`agents.sensor_model.estimate`); ``--calibrate on`` calibrates whatever is not given
(``--declared-noise-std``, ``--process-noise``, ``--initial-velocity``, ``--initial-velocity-std``,
``max_misses`` in ``--agent-kwargs`` each override their estimate), ``off`` never.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from track_envs.values.detections import Detections
from track_envs.values.types import SensorSpec


def _vector(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad --initial-velocity {text!r}: use VX,VY") from None


def add_arguments(group: Any) -> None:
    """``--calibrate``, ``--process-noise``, ``--initial-velocity``, ``--initial-velocity-std``."""
    group.add_argument(
        "--calibrate",
        choices=["auto", "on", "off"],
        default="auto",
        help="estimate the noise, process noise, velocity prior and coasting from the detections: auto "
        "(default) when --declared-noise-std is not given, on, off",
    )
    group.add_argument(
        "--process-noise",
        type=float,
        metavar="Q",
        help="the Kalman predictor's process-noise intensity q in the detections' units (overrides "
        "its estimate)",
    )
    group.add_argument(
        "--initial-velocity",
        type=_vector,
        metavar="VX,VY",
        help="mean velocity of a new track, units/s (overrides its estimate)",
    )
    group.add_argument(
        "--initial-velocity-std",
        type=float,
        metavar="STD",
        help="velocity std of a new track, units/s (overrides its estimate)",
    )


def wanted(args: argparse.Namespace) -> bool:
    """Whether this point-file run calibrates itself (pose files are tracked by pose agents, which
    ``track run`` sends elsewhere before this is asked, and point agents only reach here)."""
    return args.calibrate == "on" or (args.calibrate == "auto" and args.declared_noise_std is None)


def given_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The predictor keywords the flags give (for a run that does not calibrate)."""
    out: dict[str, Any] = {}
    if args.process_noise is not None:
        out["q"] = args.process_noise
    if args.initial_velocity is not None:
        out["initial_velocity"] = np.asarray(args.initial_velocity, np.float64)
    if args.initial_velocity_std is not None:
        out["initial_velocity_std"] = args.initial_velocity_std
    return out


def calibrated(
    args: argparse.Namespace, detections: Detections, spec: SensorSpec, agent_kwargs: dict[str, Any]
) -> tuple[SensorSpec, dict[str, Any], Any]:
    """The spec and agent keywords of a self-calibrated run, and the calibration."""
    from agents.files.points import takes_calibration
    from agents.sensor_model import estimate_sensor_model

    predictor = args.predictor or "kf-ca"
    gnn_kwargs = {k: v for k, v in agent_kwargs.items() if args.agent == "gnn"}
    cal = estimate_sensor_model(
        detections,
        spec,
        predictor=predictor,
        noise_std=args.declared_noise_std,
        q=args.process_noise,
        velocity_mean=None
        if args.initial_velocity is None
        else np.asarray(args.initial_velocity, np.float64),
        velocity_std=args.initial_velocity_std,
        agent_kwargs=gnn_kwargs,
    )
    kwargs = dict(agent_kwargs)
    if takes_calibration(args.agent):  # empty for a predictor without a kinematic model
        kwargs = cal.agent_kwargs() | kwargs
    return cal.sensor_spec(spec), kwargs, cal
