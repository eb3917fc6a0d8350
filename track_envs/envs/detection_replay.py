"""DetectionReplay-v0: a recorded detection file (no identities, no truth) replayed as observations."""

from __future__ import annotations

import os
from importlib import resources
from typing import Any

import numpy as np

from track_envs.envs.base import TrackingEnv, Truth
from track_envs.infra.atomic import atomic_path
from track_envs.values.detections import Detections, detection_sensor_spec

#: What ``info["truth_note"]`` and the metrics note say.
NO_TRUTH = "DetectionReplay-v0 replays detections without ground truth: no truth, reward 0"


def sample_detections_path() -> str:
    """Path of the detection file shipped with the package (see
    `SAMPLE_READ_OPTIONS`)."""
    return str(resources.files("track_envs") / "data" / "detections_sample.zip")


#: How the shipped sample is read: 200 frames of BeltSorter-v0's detections (defaults, seed 0,
#: 0.1 mm noise, rounded to 1 µm), in metres; columns ``frame,count,time,x0,y0,...``. Made by
#: ``python -m track_envs.envs.detection_replay``
#: ([`make_sample`][track_envs.envs.detection_replay.make_sample]).
SAMPLE_READ_OPTIONS: dict[str, Any] = {"time_column": "time"}
#: The sample's measurement noise std (BeltSorter-v0's default), metres.
SAMPLE_NOISE_STD = 1e-4


class DetectionReplayEnv(TrackingEnv):
    """Replays a file of per-frame detections (a sorter's centroids, a MOTChallenge ``det.txt``).

    ## Description
    Each frame's observation is the file's detections of that frame (as float32, rows shuffled
    like every env's; ``shuffle=False`` keeps the file's order, which is what ``track run`` uses).
    There is no ground truth: ``info["truth"]`` is empty (one padding row, id −1),
    ``info["has_truth"]`` is False and ``info["truth_note"]`` says so, every
    ``info["detection_ids"]`` is −1. [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics] skips the
    metrics that need truth (all of the point metrics) and says so in
    ``info["episode_metrics_note"]``. File formats: `track_envs.io.detections`.

    ## Observation
    ``Dict(detections=Box(max_detections, 2) float32, mask=Box(max_detections,) int8)``.

    ## Action
    The tracker's report (see `track_envs.contracts.report`).

    ## Reward
    0 every frame (there is no truth to score against).

    ## Starting State
    The file's first frame.

    ## Episode End
    Terminates after the last frame of the file.

    ## Arguments
    - ``path``: the detection file; default the sample shipped with the package
      ([`sample_detections_path`][track_envs.envs.sample_detections_path]).
    - ``detections``: a [`Detections`][track_envs.Detections] stream instead of a file.
    - ``format``: ``"auto"`` (``.txt``: MOTChallenge, else wide), ``"mot"`` or ``"wide"``.
    - ``read_options``: keyword arguments of the reader (``read_mot_detections`` /
      ``read_wide_detections``: ``frame_column``, ``count_column``, ``time_column``,
      ``xy_columns``, ``swap_xy``, ``scale``, ``min_confidence``, ...).
    - ``dt``: frame period in seconds; default inferred from the file's time column (an error
      when it has none).
    - ``region``: ``((x_low, y_low), (x_high, y_high))``; default the detections' bounding box + 2%.
    - ``measurement_noise_std``: the measurement noise std the sensor spec declares (the
      tracker's R), in the detections' units; default 0 (the sample: 1e-4).
    - ``p_detect``, ``clutter_rate``: declared in the sensor spec (defaults 1, 0).
    - ``max_detections``, ``max_tracks``: rows of the observation and the report; default the
      fullest frame (at least 16) and twice that (at least 16).
    - ``shuffle``: shuffle the detection rows each frame (default True).
    - ``nozzle_offset``: distance in the detections' units from the region's ``x_high`` (the end
      of the camera window) to the nozzle bar (> 0), as in BeltSorter-v0 and BeltReplay-v0:
      ``sensor_spec.sorting_line`` is ``x_high + nozzle_offset``, so a tracker (the gnn agent)
      predicts each track's crossing of the bar in its report's sorting channel. There is no
      crossing truth to score them (see ``track run --sorting-check`` for a truth-free check).
      Default None: no nozzle bar. The observations are the same either way.
    - ``render_mode``: ``"rgb_array"`` or ``"human"``.

    ## Version History
    - v0: the first version; its streams are those it had when added
      (2026-12-01), pinned since 2026-12-02. Added without changing them: ``nozzle_offset``
      (default None) sets ``sensor_spec.sorting_line``.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 100}  # noqa: RUF012
    has_truth = False
    gospa_c = 0.005

    def __init__(
        self,
        *,
        path: str | os.PathLike[str] | None = None,
        detections: Detections | None = None,
        format: str = "auto",
        read_options: dict[str, Any] | None = None,
        dt: float | None = None,
        region: tuple[tuple[float, float], tuple[float, float]] | None = None,
        measurement_noise_std: float | None = None,
        p_detect: float = 1.0,
        clutter_rate: float = 0.0,
        max_detections: int | None = None,
        max_tracks: int | None = None,
        shuffle: bool = True,
        nozzle_offset: float | None = None,
        render_mode: str | None = None,
    ):
        import dataclasses

        from track_envs.envs.nozzle import check_nozzle_offset
        from track_envs.io.detections import read_detections

        if detections is not None and path is not None:
            raise ValueError("give either path or detections, not both")
        sample = detections is None and path is None
        if detections is None:
            self.path: str | None = sample_detections_path() if sample else str(path)
            options = dict(SAMPLE_READ_OPTIONS if sample and read_options is None else read_options or {})
            detections = read_detections(self.path, format, **options)
        else:
            self.path = None
        if not isinstance(detections, Detections):
            raise ValueError(
                "detections must be a track_envs.values.detections.Detections, "
                f"got {type(detections).__name__}"
            )
        if detections.dim != 2:
            raise ValueError(f"DetectionReplay-v0 replays 2-d points; the detections are {detections.dim}-d")
        if not isinstance(shuffle, bool):
            raise ValueError(f"shuffle must be True or False, got {shuffle!r}")
        if measurement_noise_std is None:
            measurement_noise_std = SAMPLE_NOISE_STD if sample else 0.0
        self.detections = detections
        self.shuffle_rows = shuffle
        spec = detection_sensor_spec(
            detections,
            dt=dt,
            region=region,
            measurement_noise_std=measurement_noise_std,
            p_detect=p_detect,
            clutter_rate=clutter_rate,
            max_detections=max_detections,
            max_tracks=max_tracks,
        )
        self.nozzle_offset = check_nozzle_offset(nozzle_offset, high=np.inf)
        if self.nozzle_offset is not None:
            spec = dataclasses.replace(spec, sorting_line=spec.region_high[0] + self.nozzle_offset)
        low, high = np.asarray(spec.region_low), np.asarray(spec.region_high)
        if len(detections):  # observation bounds hold every detection, even outside a given region
            low, high = (
                np.minimum(low, detections.points.min(axis=0)),
                np.maximum(high, detections.points.max(axis=0)),
            )
        margin = 0.05 * float(np.max(high - low))
        self._setup_spaces(
            spec,
            added_noise_std=0.0,
            max_targets=1,
            obs_low=low - margin,
            obs_high=high + margin,
            render_mode=render_mode,
        )
        self._index = 0

    @property
    def n_frames(self) -> int:
        """Frames in the file."""
        return self.detections.n_frames

    # -- replay -------------------------------------------------------------------------------
    def _reset_scene(self) -> None:
        self._index = 0

    def _advance(self) -> bool:
        self._index += 1
        return self._index >= self.n_frames

    def _truth(self) -> Truth:
        return self._empty_truth()

    def _sense(self, truth: Truth) -> tuple[np.ndarray, np.ndarray]:
        z = self.detections.frame(self._index)
        return z, np.full(len(z), -1, dtype=np.int64)

    def _score(self, truth: Truth, report: Any) -> float:
        return 0.0

    def _observe(self, ended: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
        obs, info = super()._observe(ended)
        info["has_truth"] = False
        info["truth_note"] = NO_TRUTH
        return obs, info

    def default_metrics(self) -> list[Any]:
        """None of the point metrics: each needs ground truth (see ``TrackingMetrics``' note)."""
        return []

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        from track_envs.envs.rendering import Canvas

        return Canvas.for_region(self.sensor_spec)

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        """Nothing of a scene: there is no truth to draw (detections and tracks come on top)."""

    def _legend(self) -> list[Any]:
        from track_envs.envs.rendering import LegendEntry

        return [LegendEntry("detection", "cross", (0, 0, 0)), LegendEntry("track", "ring")]


def make_sample(path: str | os.PathLike[str], n_frames: int = 200, seed: int = 0) -> Detections:
    """Write the shipped sample: ``n_frames`` of BeltSorter-v0's detections (defaults; seed ``seed``)
    as a wide CSV (``frame,count,time,x0,y0,...``) inside a zip."""
    import tempfile
    import zipfile
    from pathlib import Path

    import gymnasium as gym

    from track_envs.contracts.report import empty_report
    from track_envs.io.detections import write_wide_detections

    env = gym.make("BeltSorter-v0")
    obs, info = env.reset(seed=seed)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))  # type: ignore[attr-defined]
    frames, times = [], []
    for _ in range(n_frames):  # to the micrometre (the noise is 100 µm): a small file
        frames.append(np.round(obs["detections"][obs["mask"] == 1].astype(np.float64), 6))
        times.append(info["t"])
        obs, _, _, _, info = env.step(report)
    stream = Detections.from_frames(frames, times=np.asarray(times))
    target = Path(path)
    with tempfile.TemporaryDirectory() as tmp:
        csv_path = Path(tmp) / (target.stem + ".csv")
        write_wide_detections(csv_path, stream)
        with (
            atomic_path(target) as part,
            zipfile.ZipFile(part, "w", compression=zipfile.ZIP_DEFLATED) as archive,
        ):
            archive.write(csv_path, csv_path.name)
    return stream


if __name__ == "__main__":
    print(make_sample(sample_detections_path()).n_frames, "frames written to", sample_detections_path())
