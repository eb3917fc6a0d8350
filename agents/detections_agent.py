"""The no-tracking baseline: every detection is reported as a track of its own."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import pack_report
from track_envs.values.types import SensorSpec


class DetectionsAgent:
    """Reports each detection of a frame as a fresh track (new id every frame).

    The floor every tracker should beat: positions are as good as the sensor (GOSPA reflects
    only noise, misses and clutter), but no identity survives a frame, so every association
    metric is at its worst. Works on every point environment. A reference, not a tracker.
    """

    def __init__(self) -> None:
        self._spec: SensorSpec | None = None
        self._next_id = 0

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start a new episode with the sensor ``spec`` (``seed`` is unused: the agent is deterministic)."""
        self._spec = spec
        self._next_id = 0

    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """Report the masked-in detections of ``obs`` as tracks.

        Raises:
            ValueError: for an observation that breaks the contract (see
                [`check_observation`][track_envs.contracts.check_observation]).
            ReportOverflowError: more detections than ``spec.max_tracks`` report rows (none is
                dropped silently; [`agents.files.points.run_agent`][agents.run_agent] grows the report).
        """
        if self._spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        rows, positions = check_observation(obs, self._spec)
        n = len(rows)
        ids = np.arange(self._next_id, self._next_id + n, dtype=np.int64)
        report = pack_report(ids, positions, rows, self._spec.max_tracks)
        self._next_id += n
        return report
