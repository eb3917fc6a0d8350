"""The public API of ``track_envs``, ``predictors``, ``agents`` and ``track_apps``: what each package
exports, pinned.

Every package (and the module ``track_envs.testing``) names its public names in ``__all__``; the
lists below pin them, so that a rename or a removal is a deliberate change of this file. Every
name resolves (the heavy ones load on first access), importing the packages stays light (no torch,
no numba), and the examples and the Python blocks of README.md and docs/ import only names a
package exports (or from a module in `MODULE_IMPORTS_ALLOWED`, none today).

To change a package's public names: edit the import of the name in its ``__init__.py``, from which
[`track_envs.infra.lazy`][track_envs.infra.lazy] derives ``__all__``, then its list in `PUBLIC` (the pin).
"""

from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: The public names of each package (and of the module ``track_envs.testing``), sorted.
PUBLIC: dict[str, list[str]] = {
    "agents": [
        "AGENTS",
        "Agent",
        "AgentCapability",
        "AgentTraits",
        "Association",
        "Associator",
        "AssociatorCapability",
        "EpisodeResult",
        "FrameContext",
        "PointTracker",
        "SensorModelEstimate",
        "agent_applies_to",
        "agent_capability",
        "agent_traits",
        "available_agents",
        "available_associators",
        "estimate_sensor_model",
        "make_agent",
        "make_associator",
        "register_agent",
        "register_associator",
        "run_agent",
        "run_episode",
        "run_pose_agent",
    ],
    "track_apps": [],
    "track_apps.bench": [
        "Cell",
        "Group",
        "NO_PREDICTOR",
        "aggregate",
        "expand",
        "load_records",
        "load_suite",
        "plan",
        "run_cell",
        "run_cells",
        "suite_names",
        "terminal_table",
        "write_record",
        "write_tables",
    ],
    "track_apps.bench.claims": [
        "available_claims",
        "claims_module",
    ],
    "track_apps.cli": [
        "build_parser",
        "main",
    ],
    "agents.files": [
        "check_file_agent",
        "file_agents",
        "run_agent",
        "run_pose_agent",
    ],
    "agents.gnn": [
        "GnnAgent",
    ],
    "agents.jpda": [
        "EventWeights",
        "GateClusters",
        "MAX_EXACT",
        "Marginals",
        "association_marginals",
        "cluster_marginals",
        "gate_clusters",
        "gaussian_log_likelihood",
        "jpda_log_weights",
        "jpda_marginals",
    ],
    "agents.particle": [
        "ParticleFilterAgent",
    ],
    "agents.pose": [
        "PoseBaselineAgent",
        "PoseSmcAgent",
        "PoseTracker",
        "PoseTrackingOptions",
    ],
    "track_apps.reproductions": [
        "jung2019",
    ],
    "agents.sensor_model": [
        "SensorModelEstimate",
        "estimate_sensor_model",
        "run_warnings",
    ],
    "agents.sorting": [
        "MAX_STEPS",
        "SortingCheck",
        "SortingCollector",
        "check_sorting",
        "predict_crossings",
        "sorting_spec",
    ],
    "agents.tracking": [
        "Association",
        "Associator",
        "AssociatorCapability",
        "FrameContext",
        "GatedAssignment",
        "PointTracker",
        "SecondChance",
        "SharedBlobs",
        "VelocityPriorState",
        "associator_capability",
        "available_associators",
        "chi2_gate",
        "hard_update",
        "mahalanobis_cost",
        "make_associator",
        "register_associator",
    ],
    "track_apps.tuning": [
        "ENV_ID",
        "FixedPolicy",
        "Knob",
        "NisRule",
        "SensorInformedPolicy",
        "TunedPolicy",
        "episode_errors",
        "knob_ranges",
        "load_policy",
        "make_knobs",
        "paired",
        "register_tuning_env",
    ],
    "track_envs": [
        "Detections",
        "ENV_IDS",
        "Gaussian",
        "PoseStream",
        "SensorSpec",
        "Tracks",
        "detection_sensor_spec",
        "pose_sensor_spec",
        "register_envs",
    ],
    "track_envs.contracts": [
        "ID_LIMIT",
        "OBSERVATION_KEYS",
        "REPORT_KEYS",
        "Report",
        "ReportOverflowError",
        "ReportSpace",
        "SORTING_KEYS",
        "SortingPredictions",
        "check_observation",
        "empty_report",
        "empty_sorting",
        "pack_observation",
        "pack_report",
        "pack_sorting",
        "report_space",
        "validate_report",
        "validate_sorting",
    ],
    "track_envs.envs": [
        "BeltParams",
        "BeltReplayEnv",
        "BeltSorterEnv",
        "Canvas",
        "DRIFT_PRESETS",
        "DetectionReplayEnv",
        "KeypointWalkersEnv",
        "LegendEntry",
        "PARTICLE_KINDS",
        "PiecewiseTargetEnv",
        "RandomWalk",
        "SAMPLE_NOISE_STD",
        "SAMPLE_READ_OPTIONS",
        "SensorDrift",
        "SineTargetEnv",
        "SingleTargetEnv",
        "Steps",
        "TrackingEnv",
        "Truth",
        "WorldToPixel",
        "record_belt_sorter",
        "record_keypoint_walkers",
        "recorded_crossings",
        "resolve_drift",
        "sample_detections_path",
        "sample_recording_path",
    ],
    "track_envs.infra": [
        "Declarations",
        "Registry",
        "UnknownArgumentError",
        "check_int",
        "check_non_negative",
        "check_number",
        "check_positive",
        "check_probability",
        "check_vector",
        "njit",
        "takes_keywords_of",
    ],
    "track_envs.infra.assignment": [
        "linear_sum_assignment",
        "min_cost_with_misses",
        "solve_split",
    ],
    "track_envs.io": [
        "CROSSING_COLUMNS",
        "DetectionFileError",
        "DetectionFileWarning",
        "FileWriteError",
        "MotRows",
        "POSE_FORMATS",
        "PoseFileError",
        "PoseFileWarning",
        "PredictedCrossings",
        "TRACK_FORMATS",
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
    ],
    "track_envs.metrics": [
        "AleatoricArea",
        "AssociationErrors",
        "BoxClearMot",
        "BoxHota",
        "ClearMot",
        "CrossingScore",
        "GospaMetric",
        "GospaResult",
        "Hota",
        "HotaAccumulator",
        "KeypointMota",
        "Metric",
        "MetricTraits",
        "Nees",
        "PoseHota",
        "PoseOks",
        "PredictionError",
        "Reliability",
        "SingleTargetError",
        "SortingPrediction",
        "TrackErrorDistribution",
        "box_iou",
        "gospa",
        "iou_distances",
        "keypoint_metrics",
        "mahalanobis_sq",
        "metric_traits",
        "oks",
        "pairwise_oks",
        "per_joint_mota",
        "point_metrics",
        "point_similarity",
        "pose_hota",
        "score_crossings",
        "score_poses",
        "score_tracks",
    ],
    "track_envs.streams": [
        "ConstantVelocityStream",
        "EventScores",
        "MergeEventStream",
        "MergeScene",
        "constant_density",
        "constant_velocity_stream",
        "merge_event_streams",
        "merge_scene",
        "score_events",
        "score_tracker",
    ],
    "track_envs.testing": [
        "PREDICTOR_METHODS",
        "STREAM_INFO_KEYS",
        "assert_equal_trees",
        "check_agent",
        "check_predictor",
        "check_tracking_env",
        "stream_digest",
    ],
    "track_envs.values": [
        "Detections",
        "Gaussian",
        "KEYPOINT_NAMES",
        "PoseStream",
        "SKELETON_EDGES",
        "SensorSpec",
        "Tracks",
        "carried_boxes",
        "detection_sensor_spec",
        "pose_observation",
        "pose_sensor_spec",
    ],
    "track_envs.wrappers": [
        "RecordTracking",
        "TrackingMetrics",
        "default_metrics",
    ],
    "predictors": [
        "BELT_ENVS",
        "BatchState",
        "Capability",
        "Crossings",
        "KINDS",
        "LSTMCellWeights",
        "MotionModel",
        "PREDICTORS",
        "Predictor",
        "TrainingRecipe",
        "available_predictors",
        "available_recipes",
        "capability",
        "has_capability",
        "make_predictor",
        "motion_models",
        "predictor_applies_to",
        "register_predictor",
        "register_recipe",
        "resolve_predictor",
    ],
    "predictors.belt_lstm": [
        "BeltLSTMNet",
        "LSTMPredictor",
        "shipped_weights",
    ],
    "predictors.displacement": [
        "Brownian",
        "CommonDisplacementModel",
        "ConstantVelocityDisplacement",
        "DISPLACEMENT_DECLARATIONS",
        "DISPLACEMENT_MODELS",
        "DisplacementCapability",
        "DisplacementModel",
        "LEARNED_MODELS",
        "STEP",
        "check_sigma",
        "displacement_capability",
        "make_displacement_model",
        "motion_models",
    ],
    "predictors.displacement_lstm": [
        "DisplacementLSTM",
        "DisplacementLSTMNet",
        "LSTMDisplacement",
        "shipped_displacement_weights",
    ],
    "predictors.kalman": [
        "KalmanPredictor",
        "KalmanState",
        "kalman_crossings",
    ],
    "predictors.pose": [
        "ConstantVelocityPose",
        "POSE_MOTIONS",
        "POSE_MOTION_DECLARATIONS",
        "PoseMotion",
        "PoseMotionCapability",
        "centroid_fill",
        "motion_models",
        "pose_motion_capability",
    ],
    "predictors.pose_lstm": [
        "PosePredictor",
        "PosePredictorNet",
        "SmcPoseMotion",
        "SmcSettings",
    ],
    "predictors.training": [
        "DataSettings",
        "History",
        "ModelFile",
        "ModelFileError",
        "OneStepResult",
        "RECIPES",
        "Recalibration",
        "RecipeOption",
        "TrackSet",
        "TrackSplit",
        "TrainConfig",
        "TrainingRecipe",
        "TrainingSettings",
        "available_recipes",
        "fit",
        "fit_recalibration",
        "load_model",
        "model_paths",
        "one_step_predictions",
        "pad_tracks",
        "register_recipe",
        "require_shapes",
        "save_model",
        "seeded_init",
        "split_tracks",
        "tracks_from_env",
        "tracks_from_file",
        "tracks_from_positions",
        "trained_model_file",
        "training_recipe",
    ],
}

#: The top-level packages whose every package is pinned in `PUBLIC`.
PINNED_ROOTS = ("track_envs", "predictors", "agents", "track_apps")

#: Top-level packages whose imports in examples and docs need only come from a package (not yet
#: from a pinned name).
PACKAGE_ROOTS: tuple[str, ...] = ()

#: Modules (not packages) that examples and docs may import from: the module and why.
MODULE_IMPORTS_ALLOWED: dict[str, str] = {}

#: Public names that are also the name of a submodule of their package: imported eagerly, after the
#: submodule, so the name wins. A lazily loaded name must not be a submodule's name (the import of
#: the submodule would replace it).
SHADOWING_ALLOWED: dict[str, set[str]] = {
    "predictors": {"motion_models"},
    "track_envs.metrics": {"gospa"},
    "track_apps.reproductions": {"jung2019"},  # the module is the public name
}

#: Modules importing ``track_envs`` and ``predictors`` must not load.
HEAVY = ("torch", "numba", "scipy", "pymunk", "pygame", "matplotlib")

UPDATE = (
    "if the change is deliberate, update the package's list in PUBLIC (tests/test_public_api.py) "
    "and the docs that name it"
)


def packages(root: str) -> list[str]:
    """Dotted names of ``root`` and of every package below it."""
    base = ROOT / root
    return sorted(".".join((root, *p.parent.relative_to(base).parts)) for p in base.rglob("__init__.py"))


def test_every_package_is_pinned():
    found = {name for root in PINNED_ROOTS for name in packages(root)} | {"track_envs.testing"}
    pinned = {name for name in PUBLIC if name.split(".")[0] in PINNED_ROOTS}
    assert found == pinned, (
        f"packages without a pinned list: {sorted(found - pinned)}; "
        f"pinned lists of no package: {sorted(pinned - found)}; {UPDATE}"
    )


@pytest.mark.parametrize("package", sorted(PUBLIC))
def test_public_names_are_pinned(package):
    module = importlib.import_module(package)
    exported = getattr(module, "__all__", None)
    assert exported is not None, f"{package} has no __all__"
    assert len(set(exported)) == len(exported), f"{package}.__all__ repeats a name"
    assert sorted(exported) == PUBLIC[package], (
        f"{package}.__all__ changed: added {sorted(set(exported) - set(PUBLIC[package]))}, "
        f"removed {sorted(set(PUBLIC[package]) - set(exported))}; {UPDATE}"
    )


@pytest.mark.parametrize("package", sorted(PUBLIC))
def test_every_public_name_resolves(package):
    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert not missing, f"{package}.__all__ names {missing}, which {package} does not provide"
    star: dict[str, object] = {}
    exec(f"from {package} import *", star)
    assert set(module.__all__) <= set(star), package


@pytest.mark.parametrize("package", sorted(PUBLIC))
def test_no_public_name_is_a_submodule(package):
    path = Path(importlib.import_module(package).__file__ or "")
    if path.name != "__init__.py":
        return
    submodules = {p.stem for p in path.parent.glob("*.py")} | {
        p.parent.name for p in path.parent.glob("*/__init__.py")
    }
    shadowed = set(PUBLIC[package]) & submodules - SHADOWING_ALLOWED.get(package, set())
    assert not shadowed, f"{package} exports {sorted(shadowed)}, also the name(s) of its submodules"


def test_importing_the_packages_is_light():
    code = (
        "import sys, track_envs, predictors; "
        f"print(' '.join(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == [], f"import track_envs, predictors loads {out.stdout.split()}"


def code_sources() -> list[tuple[str, str]]:
    """(where, source) of every example and every Python block of README.md and docs/**/*.md."""
    found = [
        (str(p.relative_to(ROOT)), p.read_text(encoding="utf-8")) for p in sorted(ROOT.glob("examples/*.py"))
    ]
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"^```python\n(.*?)^```", text, re.M | re.S):
            line = text.count("\n", 0, m.start()) + 1
            found.append((f"{page.relative_to(ROOT)}:{line}", m.group(1)))
    return found


def is_package(module: str) -> bool:
    return (ROOT / Path(*module.split(".")) / "__init__.py").is_file()


def import_problems(source: str) -> list[str]:
    """What the imports of ``source`` take from outside the public API."""
    problems: list[str] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            imported = [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            imported = [(node.module, alias.name) for alias in node.names]
        else:
            continue
        for module, name in imported:
            root = module.split(".")[0]
            if root in PINNED_ROOTS:
                if module not in PUBLIC:
                    problems.append(f"line {node.lineno}: {module} is not a public package")
                    continue
                elif name is not None and name not in PUBLIC[module] and f"{module}.{name}" not in PUBLIC:
                    problems.append(f"line {node.lineno}: {module} does not export {name}")
            elif root in PACKAGE_ROOTS and not is_package(module) and module not in MODULE_IMPORTS_ALLOWED:
                problems.append(f"line {node.lineno}: {module} is a module, not a package")
    return list(dict.fromkeys(problems))


SOURCES = code_sources()


@pytest.mark.parametrize("where,source", SOURCES, ids=[where for where, _ in SOURCES])
def test_examples_and_docs_import_public_names(where, source):
    problems = import_problems(source)
    assert not problems, (
        f"{where} imports past the public API: {problems}; import the name from the package that "
        "exports it (PUBLIC in tests/test_public_api.py), or export it there"
    )
