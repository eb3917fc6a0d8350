"""Readers and writers of files: detections, tracks (MOT, wide, long), recorded positions,
predicted crossings and pose files, on one CSV parser (:mod:`~track_envs.io.csv_parser`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.infra.atomic import FileWriteError, atomic_path, atomic_write, check_writable, save_figure
    from track_envs.io.crossings import CROSSING_COLUMNS, PredictedCrossings, read_crossings, write_crossings
    from track_envs.io.csv_parser import DetectionFileError, DetectionFileWarning, TrackFileError
    from track_envs.io.detections import (
        MotRows,
        detection_format,
        read_detections,
        read_mot_detections,
        read_mot_rows,
        read_wide_detections,
        write_mot_detections,
        write_mot_rows,
        write_wide_detections,
    )
    from track_envs.io.poses import (
        POSE_FORMATS,
        PoseFileError,
        PoseFileWarning,
        is_pose_file,
        json_pose_format,
        read_pose_file,
        write_coco_results,
        write_posetrack,
    )
    from track_envs.io.tracks import TRACK_FORMATS, output_format, read_tracks, track_format, write_tracks
    from track_envs.io.wide_tracks import load_track_csv, write_track_csv

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "DetectionFileWarning": "track_envs.io.csv_parser",
    "PoseFileError": "track_envs.io.poses",
    "PoseFileWarning": "track_envs.io.poses",
    "output_format": "track_envs.io.tracks",
    "CROSSING_COLUMNS": "track_envs.io.crossings",
    "PredictedCrossings": "track_envs.io.crossings",
    "read_crossings": "track_envs.io.crossings",
    "write_crossings": "track_envs.io.crossings",
    "FileWriteError": "track_envs.infra.atomic",
    "atomic_path": "track_envs.infra.atomic",
    "atomic_write": "track_envs.infra.atomic",
    "check_writable": "track_envs.infra.atomic",
    "save_figure": "track_envs.infra.atomic",
    "DetectionFileError": "track_envs.io.csv_parser",
    "TrackFileError": "track_envs.io.csv_parser",
    "MotRows": "track_envs.io.detections",
    "detection_format": "track_envs.io.detections",
    "read_detections": "track_envs.io.detections",
    "read_mot_detections": "track_envs.io.detections",
    "read_mot_rows": "track_envs.io.detections",
    "read_wide_detections": "track_envs.io.detections",
    "write_mot_detections": "track_envs.io.detections",
    "write_mot_rows": "track_envs.io.detections",
    "write_wide_detections": "track_envs.io.detections",
    "POSE_FORMATS": "track_envs.io.poses",
    "is_pose_file": "track_envs.io.poses",
    "json_pose_format": "track_envs.io.poses",
    "read_pose_file": "track_envs.io.poses",
    "write_coco_results": "track_envs.io.poses",
    "write_posetrack": "track_envs.io.poses",
    "TRACK_FORMATS": "track_envs.io.tracks",
    "read_tracks": "track_envs.io.tracks",
    "track_format": "track_envs.io.tracks",
    "write_tracks": "track_envs.io.tracks",
    "load_track_csv": "track_envs.io.wide_tracks",
    "write_track_csv": "track_envs.io.wide_tracks",
}

__all__ = [
    "CROSSING_COLUMNS",
    "POSE_FORMATS",
    "TRACK_FORMATS",
    "DetectionFileError",
    "DetectionFileWarning",
    "FileWriteError",
    "MotRows",
    "PoseFileError",
    "PoseFileWarning",
    "PredictedCrossings",
    "TrackFileError",
    "atomic_path",
    "atomic_write",
    "check_writable",
    "detection_format",
    "is_pose_file",
    "json_pose_format",
    "load_track_csv",
    "output_format",
    "read_crossings",
    "read_detections",
    "read_mot_detections",
    "read_mot_rows",
    "read_pose_file",
    "read_tracks",
    "read_wide_detections",
    "save_figure",
    "track_format",
    "write_coco_results",
    "write_crossings",
    "write_mot_detections",
    "write_mot_rows",
    "write_posetrack",
    "write_track_csv",
    "write_tracks",
    "write_wide_detections",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
