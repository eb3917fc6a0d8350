"""BeltReplay-v0: recorded belt tracks replayed through the tracking contract."""

from __future__ import annotations

import os
from collections.abc import Mapping
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.envs.base import TrackingEnv, Truth
from track_envs.envs.drift import SensorDrift
from track_envs.envs.nozzle import (
    check_nozzle_offset,
    pack_crossings,
    recorded_crossings,
    warn_dropped_crossings,
)
from track_envs.infra.arguments import (
    check_int,
    check_non_negative,
    check_positive,
    check_probability,
    check_vector,
)
from track_envs.io.wide_tracks import load_track_csv
from track_envs.values.types import SensorSpec


def sample_recording_path() -> str:
    """Path of the recording shipped with the package (300 frames of BeltSorter-v0, cylinders)."""
    return str(resources.files("track_envs") / "data" / "belt_sample.zip")


class BeltReplayEnv(TrackingEnv):
    """Replays recorded belt-sorter tracks (a CSV of per-frame positions) as detections.

    ## Description
    Reads a track file in the layout of published belt-sorting data sets (see
    `track_envs.io.wide_tracks`): no header, one row per frame, one ``(x, y)``
    column pair per particle, NaN where the particle is not visible; the pair index is the truth id. Each
    frame the visible particles are the truth, and the sensor model of BeltSorter-v0 turns them into
    detections: Gaussian noise ``noise_std``, detection probability ``p_detect`` and uniform clutter
    at ``clutter_rate`` over the observed region. With the defaults (no noise, no misses, no
    clutter) the detections are the recorded positions exactly (as float32).

    ## Observation
    ``Dict(detections=Box(max_detections, 2) float32, mask=Box(max_detections,) int8)``, shuffled rows.

    ## Action
    The tracker's report (see `track_envs.contracts.report`).

    ## Reward
    ``−GOSPA`` (cut-off ``gospa_c``, p = 2, α = 2) against the visible recorded positions.

    ## Starting State
    The first frame of ``frames`` (default: the first frame of the file).

    ## Episode End
    Terminates after the last frame of the range.

    ## Info
    ``t``, ``frame``, ``truth`` (``ids``, ``positions``, ``visible``, ``velocities`` by finite
    differences, zero for a particle seen once, and the nozzle bar's ``nozzle_ids``,
    ``nozzle_times``, ``nozzle_lateral``, see `track_envs.envs.nozzle`; empty
    without ``nozzle_offset``), ``detection_ids``, ``dropped_detections``, ``dropped_targets``.

    Nozzle bar: with ``nozzle_offset`` the line ``x = L = region x_high + nozzle_offset`` gets the
    crossing truth of BeltSorter-v0, from the recorded positions: a particle crosses between two
    consecutive recorded frames ``x₀ < L <= x₁``, interpolated linearly in time and ``y``. Only
    the particles inside the observed region are then visible (detected and scored as truth), and
    ``sensor_spec.sorting_line`` is ``L``. A recording that does not reach ``L`` (as the shipped
    sample, which ends at the camera window) cannot give the crossings: the constructor says so.

    ## Arguments
    - ``path``: the track file (``.csv`` or ``.zip``); default: the sample shipped with the package.
    - ``noise_std``, ``p_detect``, ``clutter_rate``: the sensor, as in BeltSorter-v0 (defaults 0, 1, 0);
      ``noise_std`` is the Gaussian noise added to the recorded positions.
    - ``measurement_noise_std``: the measurement noise std the sensor spec declares
      (``sensor_spec.noise_std``, what a tracker is told), in the file's units; default
      ``noise_std``. Give the recording's own noise here when replaying real centroids.
    - ``drift``: the sensor's drift over an episode, as in BeltSorter-v0
    (`track_envs.envs.drift`;
      default None).
    - ``frames``: ``(start, stop)`` half-open frame range; default the whole file.
    - ``dt``: frame period in seconds (default 0.01, a 100 Hz camera).
    - ``region``: ``((x_low, y_low), (x_high, y_high))`` observed region; default the bounding box
      of the recorded positions.
    - ``max_detections``, ``max_tracks``: rows of the observation and the report; default the most
      particles visible in any frame plus room for clutter (at least 16).
    - ``gospa_c``: GOSPA cut-off in the file's units (default 0.005).
    - ``nozzle_offset``: distance in the file's units from the region's ``x_high`` to the nozzle
      bar (> 0), or ``None`` (default: no nozzle bar).
    - ``render_mode``: ``"rgb_array"`` or ``"human"``.

    ## Version History
    - v0: the first version. Its streams changed once under v0 before the
      digests pinned them, and are pinned since 2026-12-02: on 2026-11-22 a certain detection
      (``p_detect=1``, the default) stopped drawing a uniform number, so the detections' shuffled
      order changed. Added without changing the streams: ``measurement_noise_std``, ``drift``
      (default None), ``nozzle_offset`` (default None: no nozzle bar).
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 100}  # noqa: RUF012

    def __init__(
        self,
        *,
        path: str | os.PathLike[str] | None = None,
        noise_std: float = 0.0,
        measurement_noise_std: float | None = None,
        p_detect: float = 1.0,
        clutter_rate: float = 0.0,
        drift: SensorDrift | Mapping[str, Any] | str | None = None,
        frames: tuple[int, int] | None = None,
        dt: float = 0.01,
        region: tuple[tuple[float, float], tuple[float, float]] | None = None,
        max_detections: int | None = None,
        max_tracks: int | None = None,
        gospa_c: float = 0.005,
        nozzle_offset: float | None = None,
        render_mode: str | None = None,
    ):
        self.path = str(path) if path is not None else sample_recording_path()
        self.tracks = load_track_csv(self.path, frames)
        self.first_frame = frames[0] if frames is not None else 0
        n_frames = self.tracks.shape[0]
        dt = check_positive("dt", dt)
        self.gospa_c = check_positive("gospa_c", gospa_c)
        visible = np.isfinite(self.tracks[..., 0])
        if not visible.any():
            raise ValueError(f"{self.path}: no particle is visible in frames {frames or (0, n_frames)}")
        self._frame_of, self._particle_of = np.nonzero(visible)
        self._offsets = np.searchsorted(self._frame_of, np.arange(n_frames + 1))
        most = int(visible.sum(axis=1).max())
        clutter_rate = check_non_negative("clutter_rate", clutter_rate)
        self._set_drift(drift)
        most_clutter = self.drift.highest("clutter_rate", clutter_rate) if self.drift else clutter_rate
        room = most + int(np.ceil(most_clutter + 6 * np.sqrt(most_clutter))) if most_clutter else most
        max_detections = max(room, 16) if max_detections is None else max_detections
        max_tracks = max(2 * most, 16) if max_tracks is None else max_tracks
        max_detections = check_int("max_detections", max_detections, 1)
        max_tracks = check_int("max_tracks", max_tracks, 1)
        if region is None:
            pts = self.tracks[visible]
            low, high = pts.min(axis=0), pts.max(axis=0)
            pad = 0.02 * np.maximum(high - low, 1e-9)
            low, high = low - pad, high + pad
        else:
            corners = region if isinstance(region, tuple | list) and len(region) == 2 else (None, None)
            low, high = check_vector("region[0]", corners[0], 2), check_vector("region[1]", corners[1], 2)
            if np.any(low >= high):
                raise ValueError(
                    f"region must be ((x_low, y_low), (x_high, y_high)) with low < high, got {region!r}"
                )
        added = check_non_negative("noise_std", noise_std)
        declared = (
            added
            if measurement_noise_std is None
            else check_non_negative("measurement_noise_std", measurement_noise_std)
        )
        self.nozzle_offset = check_nozzle_offset(nozzle_offset, high=np.inf)
        line = None if self.nozzle_offset is None else float(high[0]) + self.nozzle_offset
        self._crossings = self._recorded_crossings(line, dt)
        spec = SensorSpec(
            dt=dt,
            dim=2,
            noise_std=declared,
            p_detect=check_probability("p_detect", p_detect),
            clutter_rate=clutter_rate,
            region_low=(float(low[0]), float(low[1])),
            region_high=(float(high[0]), float(high[1])),
            max_detections=int(max_detections),
            max_tracks=int(max_tracks),
            sorting_line=line,
        )
        noisiest = self.drift.highest("noise_std", added) if self.drift else added
        margin = 10 * noisiest + 0.05 * float(np.max(high - low))
        self._setup_spaces(
            spec,
            added_noise_std=added,
            max_targets=max(most, 1),
            obs_low=low - margin,
            obs_high=high + margin,
            truth_extra_shapes={"velocities": (2,)},
            render_mode=render_mode,
        )
        self._index = 0

    def _recorded_crossings(self, line: float | None, dt: float) -> tuple[NDArray, ...]:
        """The crossings of ``x = line`` in the recording, grouped by the frame that reports them
        (frame offsets (frames + 1,), ids, times, lateral positions).

        Raises:
            ValueError: when the recording does not reach the line.
        """
        n_frames = self.tracks.shape[0]
        if line is None:
            return np.zeros(n_frames + 1, dtype=np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
        reach = float(np.nanmax(self.tracks[..., 0]))
        if reach < line:
            raise ValueError(
                f"{self.path}: the recorded positions end at x = {reach:.6g}, before the nozzle bar at "
                f"x = {line:.6g} (region x_high + nozzle_offset), so this recording cannot give the "
                "nozzle crossings; give nozzle_offset=None, or a recording that covers the bar and a "
                "region whose x_high lies at least nozzle_offset before where the positions end"
            )
        frame, ids, times, lateral = recorded_crossings(self.tracks, line, dt)
        return np.searchsorted(frame, np.arange(n_frames + 1)), ids, times, lateral

    def _padded_truth(self, truth: Truth, m: int) -> dict[str, NDArray]:
        """The base class's padded truth and the nozzle crossings reported in this frame."""
        packed = super()._padded_truth(truth, m)
        offsets, ids, times, lateral = self._crossings
        i = self._index
        lo, hi = (offsets[i], offsets[i + 1]) if i < self.n_frames else (0, 0)
        nozzle, dropped = pack_crossings(ids[lo:hi], times[lo:hi], lateral[lo:hi], self.max_targets)
        if dropped:
            warn_dropped_crossings(dropped, self._frame, self.max_targets)
        packed.update(nozzle)
        return packed

    def default_metrics(self) -> list[Any]:
        """The point metrics and, with a nozzle bar, the sorting prediction (``sorting_*``)."""
        from track_envs.metrics.sorting import SortingPrediction

        metrics = super().default_metrics()
        if self.nozzle_offset is not None:
            metrics.append(SortingPrediction())
        return metrics

    @property
    def n_frames(self) -> int:
        """Frames in the replayed range."""
        return int(self.tracks.shape[0])

    # -- simulation ---------------------------------------------------------------------------
    def _reset_scene(self) -> None:
        self._index = 0

    def _advance(self) -> bool:
        self._index += 1
        return self._index >= self.n_frames

    def _truth(self) -> Truth:
        lo, hi = self._offsets[self._index], self._offsets[self._index + 1]
        ids = self._particle_of[lo:hi]
        positions = self.tracks[self._index, ids]
        visible = (
            np.ones(len(ids), dtype=bool)
            if self.nozzle_offset is None
            else self.sensor_spec.contains(positions)
        )
        return Truth(
            ids=ids.astype(np.int64),
            positions=positions,
            visible=visible,
            extra={
                "velocities": _finite_difference_velocities(
                    self.tracks, self._index, ids, self.sensor_spec.dt
                )
            },
        )

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        from track_envs.envs.rendering import Canvas

        return Canvas.for_region(self.sensor_spec)

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        from track_envs.envs.rendering import identity_colors

        if snapshot is not None:
            canvas.discs(snapshot.positions, 4, identity_colors(snapshot.ids))


def _finite_difference_velocities(
    tracks: NDArray[np.float64], t: int, ids: NDArray[np.intp], dt: float
) -> NDArray[np.float64]:
    """Velocities (n, 2) of particles ``ids`` at frame ``t``: backward difference, else forward, else zero."""
    here = tracks[t, ids]
    back = (here - tracks[t - 1, ids]) / dt if t > 0 else np.full_like(here, np.nan)
    fwd = (tracks[t + 1, ids] - here) / dt if t + 1 < len(tracks) else np.full_like(here, np.nan)
    v = np.where(np.isfinite(back), back, fwd)
    return np.where(np.isfinite(v), v, 0.0)
