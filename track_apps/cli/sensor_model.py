"""The sensor model estimate of ``track run``: its options, and how they turn into the agent and sensor
spec.

With ``--sensor-model auto`` (the default) a run without ``--declared-noise-std`` estimates its sensor
model from the detections ([`agents.sensor_model.estimate`][agents.sensor_model.estimate]);
``--sensor-model on`` estimates whatever is not given (``--declared-noise-std``, ``--process-noise``,
``--initial-velocity``, ``--initial-velocity-std``, ``--p-detect``, ``--clutter-rate`` or
``--clutter-density``, ``--merge-extent`` and ``max_misses`` in ``--agent-kwargs`` each override their
estimate), ``off`` never.

Declared against estimated: a flag that is typed is kept as typed, in an estimating run too (its
source reads ``given``); one that is not typed is estimated by an estimating run, and takes its
default in a run that does not estimate (``p_D`` 1, no clutter, jpda's ``merge_extent``).
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


class Untyped(float):
    """A flag's default value that remembers the flag was not typed (it behaves as the float)."""


def typed(value: object) -> bool:
    """Whether a flag's value was typed (not its [`Untyped`][track_apps.cli.sensor_model.Untyped] default, not
    None)."""
    return value is not None and not isinstance(value, Untyped)


def add_arguments(group: Any) -> None:
    """``--sensor-model``, ``--process-noise``, ``--initial-velocity``, ``--initial-velocity-std``,
    ``--p-detect``, ``--clutter-rate``, ``--clutter-density``, ``--merge-extent``."""
    group.add_argument(
        "--sensor-model",
        choices=["auto", "on", "off"],
        default="auto",
        help="estimate the noise, process noise, velocity prior, coasting, detection probability, "
        "clutter density and jpda's merge extent from the detections: auto (default) when "
        "--declared-noise-std is not given, on, off",
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
    group.add_argument(
        "--p-detect",
        type=float,
        default=Untyped(1.0),
        metavar="P",
        help="detection probability p_D the tracker is told (gnn's clutter test, jpda's weights), in "
        "(0, 1]: kept as given; not given, a run that estimates its sensor model estimates it from "
        "the gaps of its confident tracks, any other run takes 1",
    )
    group.add_argument(
        "--clutter-rate",
        type=float,
        default=Untyped(0.0),
        metavar="R",
        help="clutter detections per frame over --region the tracker is told, >= 0: kept as given; "
        "not given (nor --clutter-density), a run that estimates its sensor model estimates the "
        "clutter density from the detections no track of 3 claims, any other run takes 0",
    )
    group.add_argument(
        "--clutter-density",
        type=float,
        metavar="L",
        help="the clutter as a density: detections per unit area (the detections' units after "
        "--scale, squared) and frame, >= 0; as --clutter-rate, not with it",
    )
    group.add_argument(
        "--merge-extent",
        type=float,
        metavar="E",
        help="jpda: largest distance of two tracks' predictions that may be one merged blob, in the "
        "detections' units, > 0: kept as given; not given, a run that estimates its sensor model "
        "estimates it (the boxes' median size, or a low quantile of the closest approaches of "
        "confident track pairs), any other run takes jpda's default (0.006, metres)",
    )


def wanted(args: argparse.Namespace) -> bool:
    """Whether this point-file run estimates its sensor model (pose files are tracked by pose agents,
    which ``track run`` sends elsewhere before this is asked, and point agents only reach here)."""
    return args.sensor_model == "on" or (args.sensor_model == "auto" and args.declared_noise_std is None)


def declared(
    args: argparse.Namespace, spec: SensorSpec, agent_kwargs: dict[str, Any]
) -> tuple[SensorSpec, dict[str, Any]]:
    """The spec and agent keywords with the declared sensor flags every run takes, estimating or
    not: ``--clutter-density`` as the spec's clutter rate over its region, ``--merge-extent`` as
    jpda's keyword.

    Raises:
        ValueError: ``--clutter-rate`` with ``--clutter-density``, a negative density, a merge
            extent not > 0, or ``--merge-extent`` for an agent other than jpda.
    """
    import math

    from agents.sensor_model.estimate import with_detection_model

    density = args.clutter_density
    if density is not None:
        if typed(args.clutter_rate):
            raise ValueError("give --clutter-rate or --clutter-density, not both")
        if not (math.isfinite(density) and density >= 0):
            raise ValueError(f"--clutter-density must be a finite number >= 0, got {density!r}")
        spec = with_detection_model(spec, spec.p_detect, density)
    extent = args.merge_extent
    if extent is not None:
        if args.agent != "jpda":
            raise ValueError(f"--merge-extent is jpda's; agent {args.agent!r} has no merge model")
        if not (math.isfinite(extent) and extent > 0):
            raise ValueError(f"--merge-extent must be a finite number > 0, got {extent!r}")
        agent_kwargs = agent_kwargs | {"merge_extent": extent}
    return spec, agent_kwargs


def given_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The predictor keywords the flags give (for a run that does not estimate the sensor model)."""
    out: dict[str, Any] = {}
    if args.process_noise is not None:
        out["q"] = args.process_noise
    if args.initial_velocity is not None:
        out["initial_velocity"] = np.asarray(args.initial_velocity, np.float64)
    if args.initial_velocity_std is not None:
        out["initial_velocity_std"] = args.initial_velocity_std
    return out


def estimated(
    args: argparse.Namespace, detections: Detections, spec: SensorSpec, agent_kwargs: dict[str, Any]
) -> tuple[SensorSpec, dict[str, Any], Any]:
    """The spec and agent keywords of a run that estimates its sensor model, and the estimate."""
    from agents.files.points import takes_sensor_model
    from agents.sensor_model import estimate_sensor_model

    if typed(args.p_detect) and not 0.0 < args.p_detect <= 1.0:
        raise ValueError(f"--p-detect must be in (0, 1], got {args.p_detect!r}")
    predictor = args.predictor or "kf-ca"
    gnn_kwargs = {k: v for k, v in agent_kwargs.items() if args.agent == "gnn"}
    clutter_given = typed(args.clutter_rate) or args.clutter_density is not None
    merge = agent_kwargs.get("merge_extent") if args.agent == "jpda" else None
    estimate = estimate_sensor_model(
        detections,
        spec,
        predictor=predictor,
        noise_std=args.declared_noise_std,
        q=args.process_noise,
        velocity_mean=None
        if args.initial_velocity is None
        else np.asarray(args.initial_velocity, np.float64),
        velocity_std=args.initial_velocity_std,
        p_detect=float(args.p_detect) if typed(args.p_detect) else None,
        clutter_density=spec.clutter_rate / float(np.prod(spec.region_size)) if clutter_given else None,
        merge_extent=None if merge is None else float(merge),
        agent_kwargs=gnn_kwargs,
    )
    kwargs = dict(agent_kwargs)
    if takes_sensor_model(args.agent):  # empty for a predictor without a kinematic model
        kwargs = estimate.agent_kwargs(args.agent) | kwargs
    return estimate.sensor_spec(spec), kwargs, estimate
