"""RecordTracking: save an episode's truth, detections and the agent's reports as MOT and wide files.

So that a gym run can be re-scored by external tools (py-motmetrics, TrackEval) or replayed
(BeltReplay-v0 reads the wide truth; DetectionReplay-v0 and ``track run`` read the detections).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from track_envs.io.detections import write_mot_detections, write_wide_detections
from track_envs.io.tracks import write_tracks
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

FORMATS = ("mot", "wide")
#: File names per format: (truth, tracks, detections).
FILE_NAMES = {
    "mot": ("gt.txt", "tracks.txt", "det.txt"),
    "wide": ("gt.csv", "tracks.csv", "det.csv"),
}


class RecordTracking(gym.Wrapper):
    """Records every frame of an episode and writes it when the episode ends.

    Per frame ``t`` (the observation of ``reset`` / ``step``, and the report that answers it):
    the visible truth (``info["truth"]``), the detections (masked-in rows in observation order,
    with the truth id behind each, ``info["detection_ids"]``, and the time ``info["t"]``) and the
    report (the action). When the episode terminates or is truncated, ``directory /
    episode-NNN/`` gets, for each format in ``formats``:

    ======== =============== =================== ===============================================
    format   truth           reports             detections
    ======== =============== =================== ===============================================
    mot      ``gt.txt``      ``tracks.txt``      ``det.txt`` (MOT rows, id = truth id or −1)
    wide     ``gt.csv``      ``tracks.csv``      ``det.csv`` (``frame,count,time,x0,y0,...``)
    ======== =============== =================== ===============================================

    (layouts: `track_envs.io.tracks`,
    `track_envs.io.detections`; MOT frames count from 1, wide rows from frame 0).
    A wide file needs at least one track, so an episode without any report row (or truth) writes no wide
    ``tracks.csv`` (``gt.csv``) and warns. The recorded arrays stay available as `last_episode` (``truth``,
    ``tracks``, ``detections``).

    ``track run det.csv --time-column time --max-detections N --max-tracks M ...`` (with the
    env's sensor spec) then reproduces the gym loop's reports, and ``--gt gt.csv --metrics``
    its metrics (with the MOT ``det.txt``, e1 / e2 too: its id column holds the truth ids).

    Args:
        env: A point tracking environment (positions (D,) = (2,)).
        directory: Where the episode folders go (created).
        formats: Subset of ``("mot", "wide")``.
    """

    def __init__(self, env: gym.Env, directory: str | os.PathLike[str], formats: Sequence[str] = FORMATS):
        super().__init__(env)
        shape = tuple(env.get_wrapper_attr("position_shape"))
        if shape != (2,):
            raise ValueError(f"RecordTracking records 2-d point tracks; this env's positions are {shape}")
        bad = [f for f in formats if f not in FORMATS]
        if bad or not formats:
            raise ValueError(f"formats must be a non-empty subset of {FORMATS}, got {tuple(formats)!r}")
        self.directory = Path(directory)
        self.formats = tuple(formats)
        self.episode_index = 0
        self.last_episode: dict[str, Any] | None = None
        self._reset_buffers()

    def _reset_buffers(self) -> None:
        self._truth: list[tuple[NDArray, NDArray]] = []
        self._detections: list[tuple[NDArray, NDArray]] = []
        self._times: list[float] = []
        self._reports: list[dict[str, NDArray]] = []

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._reset_buffers()
        self._keep(obs, info)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if not self._truth:
            raise RuntimeError("step() called before reset(); call env.reset(seed=...) first")
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._reports.append({k: np.array(v) for k, v in action.items()})
        if terminated or truncated:
            self.last_episode = self._episode()
            self._write(self.last_episode)
            self.episode_index += 1
            self._reset_buffers()
        else:
            self._keep(obs, info)
        return obs, float(reward), terminated, truncated, info

    def _keep(self, obs: dict[str, NDArray], info: dict[str, Any]) -> None:
        truth = info["truth"]
        live = (truth["ids"] >= 0) & truth["visible"]
        self._truth.append((truth["ids"][live].copy(), np.asarray(truth["positions"][live], np.float64)))
        rows = np.flatnonzero(obs["mask"] == 1)
        self._detections.append(
            (obs["detections"][rows].astype(np.float64), info["detection_ids"][rows].copy())
        )
        self._times.append(float(info["t"]))

    def _episode(self) -> dict[str, Any]:
        n = len(self._reports)  # frames answered by a report
        truth_rows = self._truth[:n]
        frame = np.repeat(np.arange(n), [len(ids) for ids, _ in truth_rows])
        ids = np.concatenate([ids for ids, _ in truth_rows]) if n else np.zeros(0, np.int64)
        pos = np.concatenate([p for _, p in truth_rows]) if n else np.zeros((0, 2))
        truth = Tracks(frame, ids, pos.reshape(-1, 2), n)
        dets = self._detections[:n]
        detections = Detections.from_frames(
            [z.reshape(-1, 2) for z, _ in dets],
            [i for _, i in dets],
            first_frame=0,
            times=np.asarray(self._times[:n]),
        )
        return {
            "truth": truth,
            "tracks": Tracks.from_reports(self._reports).with_frames(n),
            "detections": detections,
        }

    def _write(self, episode: dict[str, Any]) -> None:
        folder = self.directory / f"episode-{self.episode_index:03d}"
        folder.mkdir(parents=True, exist_ok=True)
        for fmt in self.formats:
            truth_name, tracks_name, det_name = FILE_NAMES[fmt]
            for name, tracks, as_truth in (
                (truth_name, episode["truth"], True),
                (tracks_name, episode["tracks"], False),
            ):
                if fmt == "wide" and not len(tracks):
                    warnings.warn(
                        f"{folder / name}: no rows to write (the wide layout needs one track)", stacklevel=3
                    )
                    continue
                write_tracks(folder / name, tracks, fmt, truth=as_truth)
            writer = write_mot_detections if fmt == "mot" else write_wide_detections
            writer(folder / det_name, episode["detections"])
