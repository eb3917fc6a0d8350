"""Collect the sorting channel of an agent's reports over a stream (for
[`agents.files.points.run_agent`][agents.run_agent]).

An agent told of a sorting line (``SensorSpec.sorting_line``) adds to each report the predicted
crossings of the tracks it let go in that frame
([`track_envs.contracts.sorting_channel`][track_envs.contracts.sorting_channel]). The collector keeps each
report's four sorting arrays by reference (no per-track work per frame) and gathers the live rows of a block
of frames at once into [`PredictedCrossings`][track_envs.io.PredictedCrossings].
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.contracts.sorting_channel import SORTING_KEYS
from track_envs.io.crossings import PredictedCrossings
from track_envs.values.types import SensorSpec


def sorting_spec(spec: SensorSpec, sorting_line: float | None) -> SensorSpec:
    """``spec`` with its sorting line set to ``sorting_line`` (``None``: ``spec`` as it is).

    Raises:
        ValueError: naming ``sorting_line``, its value and the region's ``x_high`` it must lie
            downstream of.
    """
    import dataclasses

    if sorting_line is None:
        return spec
    line = float(sorting_line)
    if not (np.isfinite(line) and line > spec.region_high[0]):
        raise ValueError(
            f"sorting_line must be a finite x downstream of the observed region (> region x_high = "
            f"{spec.region_high[0]:.6g}), got {sorting_line!r}"
        )
    return dataclasses.replace(spec, sorting_line=line)


class SortingCollector:
    """The sorting channels of a stream's reports, gathered a block of frames at a time."""

    def __init__(self, agent: Any, line: float) -> None:
        self.agent_name = type(agent).__name__
        self.line = line
        self._frames: list[tuple[NDArray, ...]] = []
        self._first = 0
        self._parts: list[PredictedCrossings] = []

    def add(self, report: Mapping[str, NDArray]) -> None:
        """Keep one frame's report's sorting arrays (by reference).

        Raises:
            ValueError: the report has no sorting channel (an agent that predicts no crossings).
        """
        try:
            self._frames.append(tuple(report[key] for key in SORTING_KEYS))
        except KeyError:
            raise ValueError(
                f"the agent ({self.agent_name}) reports no sorting predictions although the sensor has a "
                f"sorting line at x = {self.line:.6g}; the gnn agent predicts crossings (unless made with "
                "predict_sorting=False)"
            ) from None

    def gather(self) -> None:
        """Turn the frames kept so far into rows (one vectorised gather)."""
        if not self._frames:
            return
        ids, mask, mean, cov = (np.stack(arrays) for arrays in zip(*self._frames, strict=True))
        frame, row = np.nonzero(mask == 1)
        self._parts.append(
            PredictedCrossings(
                ids[frame, row], frame + self._first, mean[frame, row], cov[frame, row], self.line
            )
        )
        self._first += len(self._frames)
        self._frames = []

    def result(self) -> PredictedCrossings:
        """Every prediction of the stream, in the order made."""
        self.gather()
        if not self._parts:
            return PredictedCrossings.empty(self.line)
        parts = self._parts
        return PredictedCrossings(
            np.concatenate([p.ids for p in parts]),
            np.concatenate([p.frame for p in parts]),
            np.concatenate([p.mean for p in parts]),
            np.concatenate([p.cov for p in parts]),
            self.line,
        )
