"""Run any agent over recorded detections, outside a gym loop, and get its tracks.

[`run_agent`][agents.run_agent] tracks a stream of detections with an agent object or a registered agent's
name, optionally with the sensor model estimated from the stream first (``estimate_sensor_model=True``:
[`agent_with_estimated_sensor_model`][agents.files.points.agent_with_estimated_sensor_model],
[`agents.sensor_model`][agents.sensor_model]); the loop itself, which the estimate runs too, is
[`agents.files.loop`][agents.files.loop] (its docstring: blocks of packed observations, boxes,
covariances).

The command-line front end is ``track run`` ([`track_apps.cli.run`][track_apps.cli.run]).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, overload

from numpy.typing import ArrayLike

from agents.base import AGENTS, AgentCapability, agent_declares, make_agent
from agents.files.loop import track_detections
from agents.sensor_model.estimate import estimate_sensor_model, live_track_bound
from track_envs.io.crossings import PredictedCrossings
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks
from track_envs.values.types import SensorSpec


@overload
def run_agent(
    agent: Any,
    detections: Detections | Sequence[ArrayLike],
    spec: SensorSpec,
    *,
    seed: int | None = 0,
    covariance: bool = False,
    progress: bool = False,
    reset: bool = True,
    grow: bool = True,
    estimate_sensor_model: bool = False,
    sorting_line: None = None,
) -> Tracks: ...


@overload
def run_agent(
    agent: Any,
    detections: Detections | Sequence[ArrayLike],
    spec: SensorSpec,
    *,
    seed: int | None = 0,
    covariance: bool = False,
    progress: bool = False,
    reset: bool = True,
    grow: bool = True,
    estimate_sensor_model: bool = False,
    sorting_line: float,
) -> tuple[Tracks, PredictedCrossings]: ...


def run_agent(
    agent: Any,
    detections: Detections | Sequence[ArrayLike],
    spec: SensorSpec,
    *,
    seed: int | None = 0,
    covariance: bool = False,
    progress: bool = False,
    reset: bool = True,
    grow: bool = True,
    estimate_sensor_model: bool = False,
    sorting_line: float | None = None,
) -> Tracks | tuple[Tracks, PredictedCrossings]:
    """Track a stream of detections with ``agent``; return every frame's reported tracks.

    Args:
        agent: An object with ``reset(spec, *, seed)`` and ``act(obs) -> report`` (the Agent
            protocol), or a registered agent name (``"gnn"``, ...) built with default arguments.
        detections: The stream: [`Detections`][track_envs.Detections] or one (m_t, D)
            array per frame.
        spec: The sensor spec the agent is told (see
            [`detection_sensor_spec`][track_envs.detection_sensor_spec]); ``max_detections`` must hold
            the fullest frame.
        seed: Passed to ``agent.reset`` (the same seed gives the same tracks).
        covariance: Collect the covariance of every reported position from the agent's
            ``track_covariances()`` (``TRACK_COVARIANCES``); ignored (``Tracks.cov`` None) for an
            agent that does not declare it.
        progress: Show a tqdm progress bar (frames) on stderr.
        reset: Call ``agent.reset(spec, seed=seed)`` first (False: the caller has).
        grow: When the agent has more live tracks than ``spec.max_tracks`` report rows, the
            report grows to hold them (the loop runs within
            `growable_reports`: an agent that packs its report
            with [`pack_report`][track_envs.contracts.pack_report] goes on with every track), and a
            warning names the most rows a report had; with a ``sorting_line``, or for an agent that raises
            [`ReportOverflowError`][track_envs.contracts.ReportOverflowError] itself, the agent is run again
            from the start with ``max_tracks`` doubled (at least twice the tracks that overflowed; needs
            ``reset``: an agent that was reset by the caller cannot be run again). So a report
            size never makes a valid stream fail, and as the rows of a report do not change the
            tracks of a deterministic agent, the result is the run a large enough report gives.
            ``False``: the agent's ``ReportOverflowError`` is raised.
        estimate_sensor_model: Estimate the measurement noise, the process noise, the velocity
            prior and the coasting length from ``detections`` first
            ([`estimate_sensor_model`][agents.estimate_sensor_model], as ``track run`` does when no
            noise is given) and track with them: ``spec``'s noise std is replaced, ``max_tracks``
            sized for the estimated coasting, and ``agent`` must be a registered agent's name (the
            estimate sets its keywords: an agent that declares ``SENSOR_MODEL``, gnn and
            jpda, with kf-ca gets all of them, any other agent the noise only). For the figures,
            or another predictor, call [`estimate_sensor_model`][agents.estimate_sensor_model]
            yourself and build the agent with its ``agent_kwargs()``.
        sorting_line: A sorting line ``x = sorting_line`` downstream of the region (the nozzle
            bar): the agent is told of it (``spec.sorting_line``) and the predicted crossings
            of its reports' sorting channels are returned too. ``None`` (default): ``spec`` as
            given, tracks only.

    Returns:
        [`Tracks`][track_envs.Tracks]: frame (from 0), id, position (the report's float32
            values as float64), the detection row each track was updated with (−1: coasted),
            with box detections the box of each row (``Tracks.boxes``) and, with ``covariance``,
            the covariances. A report's arrays are kept by reference until their
            block is gathered, so an agent must return fresh arrays each frame (``pack_report`` does).
            With ``sorting_line``: ``(tracks, crossings)``, ``crossings`` the
            [`PredictedCrossings`][track_envs.io.PredictedCrossings] of every report, with the
            frame each was reported in (``crossings.last()``: the one per track that counts).

    Raises:
        ValueError: a frame with more detections than ``spec.max_detections`` (named),
            detections whose dimension is not ``spec.dim``, an agent that cannot track
            recorded points (a pose agent; one that needs truth: `agents.files.kinds`);
            a ``sorting_line`` not downstream of the region, or an agent that reports no crossings.
    """
    stream = detections if isinstance(detections, Detections) else Detections.from_frames(detections)
    if estimate_sensor_model:
        agent, spec = agent_with_estimated_sensor_model(agent, stream, spec)
    if isinstance(agent, str):
        agent = make_agent(agent)
    return track_detections(
        agent,
        stream,
        spec,
        seed=seed,
        covariance=covariance,
        progress=progress,
        reset=reset,
        grow=grow,
        sorting_line=sorting_line,
    )


def takes_sensor_model(name: str) -> bool:
    """Whether agent ``name`` takes the keywords of a sensor model estimate (``agent_kwargs()`` of
    [`agents.sensor_model.estimate`][agents.sensor_model.estimate]): its registered factory declares
    ``SENSOR_MODEL`` (gnn and the trackers built on it, jpda)."""
    return agent_declares(AGENTS.factory(name), AgentCapability.SENSOR_MODEL)


def agent_with_estimated_sensor_model(
    name: Any, stream: Detections, spec: SensorSpec
) -> tuple[Any, SensorSpec]:
    """The agent ``name`` built with the settings
    [`agents.sensor_model.estimate`][agents.sensor_model.estimate] estimates from ``stream``, and ``spec``
    with the estimated noise and a report that holds every track the estimated coasting allows
    (``run_agent(..., estimate_sensor_model=True)``)."""
    if not isinstance(name, str):
        raise ValueError(
            "run_agent(estimate_sensor_model=True) needs the agent by name (e.g. 'gnn'): the "
            f"estimate sets its keywords; got {type(name).__name__}. Or call "
            "agents.sensor_model.estimate_sensor_model(...) and build the agent with its agent_kwargs()"
        )
    estimate = estimate_sensor_model(stream, spec)
    kwargs = estimate.agent_kwargs(name) if takes_sensor_model(name) else {}
    spec = estimate.sensor_spec(spec)
    rows = live_track_bound(stream, estimate.max_misses)
    return make_agent(name, **kwargs), dataclasses.replace(spec, max_tracks=max(spec.max_tracks, rows))
