"""A recorded stream of keypoint poses, frame by frame (detections, tracks or ground truth).

[`PoseStream`][track_envs.PoseStream] is the pose twin of [`Detections`][track_envs.Detections]: every frame's
poses in flat arrays (CSR layout: frame ``t`` owns rows ``offsets[t]:offsets[t + 1]``), with what
the pose file formats carry per pose (a track id, a pose score, a head box) and per frame (the
image id and file name). The readers and the writer of [`track_envs.io.poses`][track_envs.io.poses] map to it,
``agents.files.poses.run_pose_agent`` tracks it, and
[`track_envs.metrics.pose_scoring`][track_envs.metrics.pose_scoring] scores one stream against another.

Keypoints follow COCO: ``(x, y, v)`` with ``v = 0`` not labelled (``x = y = 0``), ``v = 1``
labelled but not visible, ``v = 2`` labelled and visible. A keypoint counts (is present) where
``v > 0``. Each keypoint also has a confidence in [0, 1] (``keypoint_scores``; 0 where ``v = 0``).

[`pose_observation`][track_envs.values.pose_observation] packs one frame as KeypointWalkers-v0 observes it:
``{"detections": (max_detections, K, 3) float32, "mask": (max_detections,) int8}`` with ``x, y``
and the keypoint's confidence, a confidence of 0 (and ``x = y = 0``) for a keypoint not detected.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.values.keypoints import KEYPOINT_NAMES
from track_envs.values.types import SensorSpec


@dataclass(frozen=True, eq=False)
class PoseStream:
    """Per-frame poses of one video (frame ``t`` = the ``t``-th frame of the stream, from 0).

    Attributes:
        keypoints: (N, K, 2) float64 keypoint positions (px), 0 where not labelled.
        visibility: (N, K) int8 COCO visibility 0 / 1 / 2.
        keypoint_scores: (N, K) float64 confidences in [0, 1], 0 where ``visibility == 0``.
        offsets: (n_frames + 1,) int64: frame ``t`` holds rows ``offsets[t]:offsets[t + 1]``.
        image_ids: (n_frames,) int64 image id of every frame (the file's ``image_id``).
        file_names: One image file name per frame, or None where the file names none.
        track_ids: (N,) int64 identity of each pose (ground truth, tracks), −1 where none.
        scores: (N,) float64 pose score, NaN where none.
        head_boxes: (N, 4) float64 head box ``x, y, w, h`` (PoseTrack ``bbox_head``), NaN where none.
        keypoint_names: The K keypoint names (COCO's by default).
        video_id: The video's id where the file gives one (PoseTrack ``vid_id``), else None.
    """

    keypoints: NDArray[np.float64]
    visibility: NDArray[np.int8]
    keypoint_scores: NDArray[np.float64]
    offsets: NDArray[np.int64]
    image_ids: NDArray[np.int64]
    file_names: tuple[str, ...] | None = None
    track_ids: NDArray[np.int64] = None  # type: ignore[assignment]
    scores: NDArray[np.float64] = None  # type: ignore[assignment]
    head_boxes: NDArray[np.float64] = None  # type: ignore[assignment]
    keypoint_names: tuple[str, ...] = KEYPOINT_NAMES
    video_id: str | None = None

    def __post_init__(self) -> None:
        kp = np.ascontiguousarray(self.keypoints, dtype=np.float64)
        n = len(kp)
        k = len(self.keypoint_names)
        if kp.shape != (n, k, 2):
            raise ValueError(f"PoseStream.keypoints must have shape (N, {k}, 2), got {kp.shape}")
        vis = np.ascontiguousarray(self.visibility, dtype=np.int8)
        scores = np.ascontiguousarray(self.keypoint_scores, dtype=np.float64)
        if vis.shape != (n, k) or scores.shape != (n, k):
            raise ValueError(
                f"PoseStream.visibility and keypoint_scores must have shape ({n}, {k}), got {vis.shape}, "
                f"{scores.shape}"
            )
        offsets = np.ascontiguousarray(self.offsets, dtype=np.int64)
        if offsets.ndim != 1 or len(offsets) < 1 or offsets[0] != 0 or offsets[-1] != n:
            raise ValueError(f"PoseStream.offsets must run from 0 to N={n}, got {offsets.tolist()[:5]}...")
        if np.any(np.diff(offsets) < 0):
            raise ValueError("PoseStream.offsets must be non-decreasing")
        image_ids = np.ascontiguousarray(self.image_ids, dtype=np.int64)
        if image_ids.shape != (len(offsets) - 1,):
            raise ValueError(
                f"PoseStream.image_ids must have shape ({len(offsets) - 1},), got {image_ids.shape}"
            )
        if self.file_names is not None and len(self.file_names) != len(image_ids):
            raise ValueError(
                f"PoseStream.file_names must name {len(image_ids)} frames, got {len(self.file_names)}"
            )
        track_ids = (
            np.full(n, -1, np.int64) if self.track_ids is None else np.asarray(self.track_ids, np.int64)
        )
        pose_scores = np.full(n, np.nan) if self.scores is None else np.asarray(self.scores, np.float64)
        heads = (
            np.full((n, 4), np.nan) if self.head_boxes is None else np.asarray(self.head_boxes, np.float64)
        )
        if track_ids.shape != (n,) or pose_scores.shape != (n,) or heads.shape != (n, 4):
            raise ValueError(
                f"PoseStream.track_ids, scores and head_boxes must have shapes ({n},), ({n},), ({n}, 4), got "
                f"{track_ids.shape}, {pose_scores.shape}, {heads.shape}"
            )
        for name, value in (
            ("keypoints", kp),
            ("visibility", vis),
            ("keypoint_scores", scores),
            ("offsets", offsets),
            ("image_ids", image_ids),
            ("track_ids", track_ids),
            ("scores", pose_scores),
            ("head_boxes", heads),
        ):
            object.__setattr__(self, name, value)
        if self.file_names is not None:
            object.__setattr__(self, "file_names", tuple(str(f) for f in self.file_names))
        object.__setattr__(self, "keypoint_names", tuple(self.keypoint_names))

    # -- access -------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        """Frames in the stream (frames without poses included)."""
        return len(self.offsets) - 1

    @property
    def num_keypoints(self) -> int:
        """Keypoints per pose ``K``."""
        return len(self.keypoint_names)

    @property
    def counts(self) -> NDArray[np.int64]:
        """(n_frames,) poses per frame."""
        return np.diff(self.offsets)

    @property
    def present(self) -> NDArray[np.bool_]:
        """(N, K) the labelled keypoints (``visibility > 0``)."""
        return np.asarray(self.visibility > 0, dtype=bool)

    def __len__(self) -> int:
        return len(self.keypoints)

    def frame_rows(self, t: int) -> slice:
        """The rows of frame ``t``."""
        return slice(int(self.offsets[t]), int(self.offsets[t + 1]))

    def frame_index(self) -> NDArray[np.int64]:
        """(N,) the frame of every pose."""
        return np.repeat(np.arange(self.n_frames, dtype=np.int64), self.counts)

    def head_sizes(self) -> NDArray[np.float64]:
        """(N,) PoseTrack head sizes ``0.6 · ‖(w, h)‖`` of the head boxes (NaN without one)."""
        return 0.6 * np.hypot(self.head_boxes[:, 2], self.head_boxes[:, 3])

    def with_rows(self, **columns: Any) -> PoseStream:
        """A copy with some per-pose columns replaced (``track_ids=...``, ``scores=...``, ...)."""
        return replace(self, **columns)

    def equals(self, other: PoseStream) -> bool:
        """Whether both streams hold the same frames and poses, value for value (NaN equal to NaN)."""
        same = (
            self.keypoint_names == other.keypoint_names
            and self.file_names == other.file_names
            and self.video_id == other.video_id
        )
        arrays = (
            "keypoints",
            "visibility",
            "keypoint_scores",
            "offsets",
            "image_ids",
            "track_ids",
            "scores",
            "head_boxes",
        )
        return same and all(
            getattr(self, a).shape == getattr(other, a).shape
            and np.array_equal(getattr(self, a), getattr(other, a), equal_nan=True)
            for a in arrays
        )


def pose_sensor_spec(
    stream: PoseStream,
    *,
    fps: float = 30.0,
    image_size: tuple[float, float] | None = None,
    max_detections: int | None = None,
    max_tracks: int | None = None,
) -> SensorSpec:
    """The sensor spec a pose agent is told for ``stream`` (KeypointWalkers-v0's layout).

    ``dt = 1 / fps``; the region is the image (``image_size`` = width, height) or the labelled
    keypoints' bounding box from the origin; ``max_detections`` the fullest frame (at least 16),
    ``max_tracks`` twice it (at least 16); units ``"px"``.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive frame rate, got {fps!r}")
    fullest = int(stream.counts.max()) if stream.n_frames else 0
    if image_size is None:
        xy = stream.keypoints[stream.present]
        high = (float(xy[:, 0].max()), float(xy[:, 1].max())) if len(xy) else (1.0, 1.0)
    else:
        high = (float(image_size[0]), float(image_size[1]))
    rows = max_detections if max_detections is not None else max(fullest, 16)
    if rows < fullest:
        raise ValueError(f"max_detections={rows} is below the fullest frame's {fullest} poses")
    return SensorSpec(
        dt=1.0 / fps,
        dim=2,
        noise_std=0.0,
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=(0.0, 0.0),
        region_high=(max(high[0], 1.0), max(high[1], 1.0)),
        max_detections=rows,
        max_tracks=max_tracks if max_tracks is not None else max(2 * fullest, 16),
        units="px",
    )


def pose_observation(stream: PoseStream, t: int, spec: SensorSpec) -> dict[str, NDArray]:
    """Frame ``t`` of ``stream`` as a pose agent's observation (the twin of
    [`track_envs.contracts.observation.pack_observation`][track_envs.contracts.pack_observation]): row ``i``
    is the frame's ``i``-th pose, ``x, y`` and confidence per keypoint as float32 (all 0 for a keypoint with
    confidence 0), padding rows zero, mask 0.

    Raises:
        ValueError: if the frame holds more poses than ``spec.max_detections``.
    """
    rows = stream.frame_rows(t)
    m = rows.stop - rows.start
    if m > spec.max_detections:
        raise ValueError(
            f"frame {t} (image id {stream.image_ids[t]}) holds {m} poses, more than "
            f"max_detections={spec.max_detections}"
        )
    score = stream.keypoint_scores[rows]
    det = np.zeros((spec.max_detections, stream.num_keypoints, 3), dtype=np.float32)
    det[:m, :, :2] = stream.keypoints[rows] * (score > 0)[..., None]
    det[:m, :, 2] = score
    mask = np.zeros(spec.max_detections, dtype=np.int8)
    mask[:m] = 1
    return {"detections": det, "mask": mask}
