"""What predictors imports from track_envs is what docs/architecture.md says it imports."""

from __future__ import annotations

import ast
from pathlib import Path

import predictors

#: track_envs modules every predictor may use: the value types, the registry helper, the plug-in
#: declarations, the packages' lazy exports, the compiled-kernel decorator, the BLAS thread limit
#: of a frame's small products and the keypoint similarity (OKS) the pose motions weigh by.
RUNTIME = {
    "track_envs.values.types",
    "track_envs.infra.registry",
    "track_envs.infra.declared",
    "track_envs.infra.lazy",
    "track_envs.infra.compiled",
    "track_envs.infra.blas_threads",
    "track_envs.metrics.keypoints",
}
#: and those the training recipes (``training`` modules) use besides: the envs (data from their
#: truth), the empty report, track files, the reliability metric (calibration) and atomic writes.
TRAINING = {
    "track_envs",
    "track_envs.envs.single_target",
    "track_envs.contracts.report",
    "track_envs.io.wide_tracks",
    "track_envs.metrics.prediction",
    "track_envs.infra.atomic",
}


def track_envs_imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "track_envs":
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "track_envs"}
    return found


def test_predictors_import_from_track_envs_only_what_the_architecture_page_lists():
    root = Path(predictors.__file__).parent
    for path in root.rglob("*.py"):
        name = path.relative_to(root.parent)
        training = "training" in name.with_suffix("").parts
        extra = track_envs_imports(path) - RUNTIME - (TRAINING if training else set())
        assert not extra, f"{name} imports {sorted(extra)}: update docs/architecture.md"
