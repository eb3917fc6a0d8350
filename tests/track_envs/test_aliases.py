"""The module paths of the flat layout still import, as the moved modules, with a DeprecationWarning.

envs-move: keep-old-paths (this test imports the old names on purpose)
"""

from __future__ import annotations

import importlib
import sys

import pytest

import track_envs
from track_envs.infra.moved_modules import MOVED

#: The public names of every old module (as they were defined there).
OLD_NAMES: dict[str, tuple[str, ...]] = {
    "track_envs.arguments": (
        "check_number",
        "check_probability",
        "check_non_negative",
        "check_positive",
        "check_int",
        "check_vector",
    ),
    "track_envs.compiled": ("PACKAGE_ROOTS", "STAMPED_CACHE", "njit", "project_kernel_digest"),
    "track_envs.registry": (
        "UnknownArgumentError",
        "named_arguments",
        "keyword_arguments",
        "check_keywords",
        "missing_methods",
        "Registry",
        "F",
        "keyword_parameters",
        "split_keywords",
        "takes_keywords_of",
    ),
    "track_envs.assignment": (
        "IntArray",
        "Pairs",
        "EMPTY_PAIRS",
        "split_lone_pairs",
        "split_dense",
        "split_sparse",
        "partner_pairs",
        "rest_problem",
        "merge_solution",
        "solve_split",
        "min_cost_with_misses",
    ),
    "track_envs.metrics.shortest_augmenting_path": ("linear_sum_assignment",),
    "track_envs.types": ("FloatArray", "SensorSpec", "Gaussian"),
    "track_envs.tracks": ("Tracks", "carried_boxes"),
    "track_envs.poses": ("PoseStream", "pose_sensor_spec", "pose_observation"),
    "track_envs.detections": ("Detections", "detection_sensor_spec"),
    "track_envs.observation": ("OBSERVATION_KEYS", "check_observation", "pack_observation"),
    "track_envs.report": (
        "REPORT_KEYS",
        "ID_LIMIT",
        "ReportSpace",
        "report_space",
        "empty_report",
        "ReportOverflowError",
        "pack_report",
        "Report",
        "validate_report",
    ),
    "track_envs.sorting_channel": (
        "SORTING_KEYS",
        "SORTING_KEY_SET",
        "SortingPredictions",
        "empty_sorting",
        "pack_sorting",
        "validate_sorting",
    ),
    "track_envs.csv_table": ("DetectionFileError", "Table", "read_table", "first_bad"),
    "track_envs.track_csv": (
        "NA_TOKENS",
        "TrackFileError",
        "load_track_csv",
        "read_float_frame",
        "write_track_csv",
    ),
    "track_envs.track_files": (
        "TRACK_FORMATS",
        "LONG_COLUMNS",
        "COV_COLUMNS",
        "BOX_COLUMNS",
        "write_tracks",
        "read_tracks",
        "track_format",
    ),
    "track_envs.detection_files": (
        "CONSIDERED",
        "DetectionFileError",
        "FORMATS",
        "MotRows",
        "detection_format",
        "read_detections",
        "read_mot_detections",
        "read_mot_rows",
        "read_wide_detections",
        "write_mot_detections",
        "write_wide_detections",
    ),
    "track_envs.pose_files": (
        "POSE_FORMATS",
        "MAX_TRACK_IDS",
        "load_json",
        "json_pose_format",
        "is_pose_file",
        "read_pose_file",
        "image_list",
        "posetrack_track_ids",
        "posetrack_json",
        "coco_results_json",
        "write_coco_results",
        "write_posetrack",
    ),
    "track_envs.crossing_predictions": (
        "CROSSING_COLUMNS",
        "INTEGER_COLUMNS",
        "PredictedCrossings",
        "write_crossings",
        "read_crossings",
    ),
    "track_envs.recording": ("record_belt_sorter",),
    "track_envs.pose_recording": ("record_keypoint_walkers",),
    "track_envs.sensors": (
        "CLUTTER_ID",
        "check_non_negative",
        "check_positive",
        "check_probability",
        "sense_points",
    ),
    "track_envs.drift": (
        "BLOCK",
        "DRIFT_PRESETS",
        "DriftProcess",
        "RandomWalk",
        "SCHEDULES",
        "Schedule",
        "SensorDrift",
        "SensorValues",
        "Steps",
        "resolve_drift",
    ),
    "track_envs.rendering": (
        "Canvas",
        "Color",
        "FOOTER_BACKGROUND",
        "FOOTER_RULE",
        "FOOTER_TEXT",
        "LegendEntry",
        "Marker",
        "WorldToPixel",
        "footer_height",
        "identity_colors",
    ),
    "track_envs.render_window": ("HumanWindow",),
    "track_envs.track_scoring": ("MATCHES", "NO_DETECTION_IDS", "match_kind", "match_line", "score_tracks"),
    "track_envs.crossing_check": (
        "LATERAL_TOLERANCE",
        "TIME_TOLERANCE",
        "MIN_SEEN",
        "PERCENTILES",
        "ObservedCrossings",
        "updated_detections",
        "observed_crossings",
        "seen_upstream",
        "CrossingScore",
        "check_tolerances",
        "score_crossings",
    ),
}
#: Old public names that were helpers of a module that was split, and stay only at the new path.
DROPPED = {("track_envs.track_csv", "read_float_frame")}


def _forget(name: str) -> None:
    """Drop an old name from the import caches, so that importing it runs the alias again."""
    sys.modules.pop(name, None)
    parent, _, child = name.rpartition(".")
    if parent in sys.modules and child in vars(sys.modules[parent]):
        delattr(sys.modules[parent], child)


def test_every_old_module_is_aliased():
    assert set(OLD_NAMES) == set(MOVED)


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_path_imports_the_new_module_and_warns(old):
    new = importlib.import_module(MOVED[old])
    _forget(old)
    with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated.*import {MOVED[old]} instead"):
        module = importlib.import_module(old)
    assert module is new
    for name in OLD_NAMES[old]:
        if (old, name) not in DROPPED:
            assert getattr(module, name) is getattr(new, name)
    _forget(old)


def test_from_package_import_old_module_warns():
    _forget("track_envs.track_files")
    with pytest.warns(DeprecationWarning, match="track_envs.io.tracks"):
        from track_envs import track_files
    from track_envs.io import tracks

    assert track_files is tracks
    assert track_envs.registration.ENV_IDS  # the package itself imports without warnings
    _forget("track_envs.track_files")


def test_new_paths_import_without_warnings(recwarn):
    for new in MOVED.values():
        importlib.import_module(new)
    assert not [w for w in recwarn if issubclass(w.category, DeprecationWarning)]
