"""Run an agent over a merge-event stream and score it per event.

The scores themselves ([`score_events`][track_envs.streams.score_events], the bounds, the
module docstring's definitions) are the environment side's,
[`track_envs.streams.merge_scoring`][track_envs.streams.merge_scoring]; this module drives the agent:
[`run_on_stream`][agents.merge_scoring.run_on_stream] feeds it every frame of a
[`MergeEventStream`][track_envs.streams.MergeEventStream] and keeps its reports and, where the agent declares
``LAST_PREDICTION`` ([`agents.base`][agents.base]: gnn, jpda), its tracker-side prediction of every frame,
which the kick score reads; [`score_agent`][agents.merge_scoring.score_agent] runs and scores a fresh agent.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from agents.base import Agent, AgentCapability, agent_capability
from track_envs.metrics import ClearMot
from track_envs.streams.merge_events import MergeEventStream
from track_envs.streams.merge_scoring import MATCH_RADIUS, EventScores, TrackHistory, score_events


def run_on_stream(
    agent: Agent, stream: MergeEventStream, seed: int = 0
) -> tuple[TrackHistory, dict[str, float]]:
    """Reset ``agent`` on the stream's spec, feed every frame, and keep the reports (and the
    predictions of an agent that declares ``LAST_PREDICTION``); with the whole-stream CLEAR MOT
    of the reports (merged ids, threshold [`MATCH_RADIUS`][track_envs.streams.merge_scoring.MATCH_RADIUS])."""
    agent.reset(stream.spec, seed=seed)
    frames, rows = len(stream), stream.spec.max_tracks
    ids = np.full((frames, rows), -1, np.int64)
    positions = np.full((frames, rows, stream.spec.dim), np.nan)
    exposes = agent_capability(agent, AgentCapability.LAST_PREDICTION)
    predicted_ids = np.full((frames, rows), -1, np.int64)
    predicted = np.full((frames, rows, stream.spec.dim), np.nan)
    mot = ClearMot(threshold=MATCH_RADIUS)
    previous = None
    for t in range(frames):
        report = agent.act(stream.observation(t))
        live = np.asarray(report["mask"]) == 1
        ids[t] = np.where(live, report["ids"], -1)
        positions[t][live] = np.asarray(report["positions"], np.float64)[live]
        mot.update(stream.truth(t), stream.detection_ids[t], report)
        prediction = exposes.last_prediction if exposes is not None else None
        if exposes is not None and prediction is not None and prediction is not previous:  # live tracks
            k = len(exposes.last_prediction_ids)
            predicted_ids[t, :k] = exposes.last_prediction_ids
            predicted[t, :k] = prediction.mean
            previous = prediction
    if exposes is None:
        return TrackHistory(ids, positions), mot.compute()
    return TrackHistory(ids, positions, predicted_ids, predicted), mot.compute()


def score_agent(
    make: Callable[[], Agent], stream: MergeEventStream, seed: int = 0, **kwargs: Any
) -> EventScores:
    """[`run_on_stream`][agents.merge_scoring.run_on_stream] on a fresh ``make()``, then
    [`score_events`][track_envs.streams.score_events] (``kwargs``: its keywords)."""
    history, mot = run_on_stream(make(), stream, seed)
    return score_events(stream, history, mot, **kwargs)
