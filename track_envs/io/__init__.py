"""Readers and writers of files: detections, tracks (MOT, wide, long), recorded positions,
predicted crossings and pose files, on one CSV parser (`csv_parser`)."""

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

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
