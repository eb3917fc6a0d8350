"""Readers and writers of files: detections, tracks (MOT, wide, long), recorded positions,
predicted crossings and pose files, on one CSV parser (:mod:`~track_envs.io.csv_parser`)."""
