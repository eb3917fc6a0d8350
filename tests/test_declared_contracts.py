"""Plug-ins are asked what they offer through their declarations, never probed (AST checks).

A plug-in (an agent, a predictor, a displacement model, a pose motion, a tuning policy) declares
its optional capabilities and traits ([`track_envs.infra.declared`][track_envs.infra.declared]); the code in
``agents/``, ``predictors/`` and ``track_envs/`` asks through that declaration. These tests walk every module
there (so moving or adding modules needs no change here) and refuse:

1. ``getattr(...)`` / ``hasattr(...)`` outside [`track_envs.infra.declared`][track_envs.infra.declared],
except the uses listed
   in `ALLOWED_PROBES`, each with the reason it is not a plug-in probe (a dataclass's own
   fields, numba internals, an argparse namespace, a knob set by its declared name, ...);
2. ``isinstance`` / ``issubclass`` against a ``typing.Protocol`` class of the project (a runtime
   protocol check recognises a plug-in by the names it happens to have);
3. a private name imported from another module (``from x import _y``): a private name is private
   to its module, so a caller needs a public one (e.g. ``KalmanPredictor.kinematic_model`` rather
   than ``predictors.kalman.predictor._kinematic_model``). The rule for private *modules*
   (``from pkg import _mod``, ``from pkg._mod import y``, public names only): a ``_kernels``
   module (compiled kernels) may be imported anywhere in its top-level package (``agents``'
   trackers share ``agents.tracking._kernels``; ``predictors`` and ``track_envs`` never import
   an agent's kernels), any other private module only inside its own package. The existing
   exceptions are listed in `ALLOWED_PRIVATE_IMPORTS`, each with its reason.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("agents", "predictors", "track_envs", "track_apps")
#: The one module that reads declarations.
DECLARATION_MODULE = "track_envs/infra/declared.py"

#: ``(module file name, source of the probe's first argument)`` → why it is not a plug-in probe.
#: Keyed by file name, not path, so that moving a module between folders keeps its entry.
ALLOWED_PROBES: dict[tuple[str, str], str] = {
    # a BLAS library's own entry points, found in the shared object threadpoolctl loaded
    ("blas_threads.py", "controller"): "threadpoolctl's controller of one BLAS library (its ABI)",
    ("blas_threads.py", "controller.dynlib"): "the BLAS library's own set/get thread-count functions",
    # dataclass fields and records iterated by their own declared field names
    ("base.py", "self"): "BatchState / env params: a dataclass's own fields by name",
    ("base.py", "born"): "BatchState.take_and_append: the same dataclass's fields by name",
    ("base.py", "s"): "BatchState.concat: the same dataclass's fields by name",
    ("mc_dropout.py", "s"): "a state dataclass's fields by name",
    ("network.py", "self"): "a config dataclass's fields by name",
    ("features.py", "self"): "the input features dataclass's fields by name",
    ("motion.py", "self"): "SmcPoseMotion's own per-track arrays by name",
    ("tracks.py", "p"): "Tracks parts: a dataclass's fields by name",
    ("poses.py", "self"): "PoseStream.__eq__: its own fields by name",
    ("poses.py", "other"): "PoseStream.__eq__: the other stream's same fields",
    ("belt_physics.py", "self"): "BeltParams validation: its own fields by name",
    ("skeleton.py", "self"): "WalkerParams validation: its own fields by name",
    ("drift.py", "self"): "SensorDrift: its own schedule fields by name",
    ("drift.py", "drift"): "SensorDrift: a drift's schedule fields by name",
    ("drift.py", "self.nominal"): "SensorDrift: the nominal sensor's fields by name",
    ("informed.py", "preset"): "a drift preset's schedule fields by name",
    ("tracker.py", "self"): "PoseTrackingOptions: its own fields by name",
    ("command.py", "config"): "a training config dataclass's fields by name",
    ("merge_scoring.py", "s"): "EventScores: a dataclass's fields by name",
    # numpy / numba / stable-baselines3 / os internals, not plug-ins
    ("belt_sorter.py", "np.random"): "a replay's recorded bit generator, by numpy's name",
    ("compiled.py", "caching"): "numba's cache locator classes, renamed between numba versions",
    ("compiled.py", "impl"): "numba's cache locator internals",
    ("compiled.py", "c"): "numba's cache locator classes: the project's marker",
    ("policy.py", "policy.features_extractor_class"): "a stable-baselines3 policy's extractor class",
    ("train.py", "os"): "os.sched_getaffinity exists on Linux only",
    # argparse namespaces: options another command's parser may not define
    ("run_pose.py", "args"): "argparse Namespace of track run: sorting options of the point parser",
    ("run.py", "args"): "argparse Namespace: argv set by main(), absent when run(args) is called",
    # the core check of a plug-in (every protocol method present), in the registries
    ("registry.py", "obj"): "track_envs.infra.registry.missing_methods: the core methods of a protocol",
    ("testing.py", "agent"): "track_envs.testing: the contract check of an agent's core methods",
    ("testing.py", "predictor"): "track_envs.testing: the contract check of a predictor's core",
    # knobs set and read by the names the capability declares
    ("env.py", "self._knobbed"): "GateTuning-v0: the gnn tracker's live knobs, by knob name",
    ("env.py", "self.base.unwrapped"): "gymnasium env attributes",
    # not yet converted (files owned elsewhere): metrics' and predictor factories' traits
}


#: ``(module file name, imported private name)`` → why it is imported (by file name: robust to moves).
ALLOWED_PRIVATE_IMPORTS: dict[tuple[str, str], str] = {
    ("marginals.py", "_cluster_marginals"): "jpda's compiled cluster marginals (jpda being rewritten)",
}


def _modules() -> Iterator[tuple[Path, ast.Module]]:
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            yield path, ast.parse(path.read_text(), filename=str(path))


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _called(node: ast.AST, names: tuple[str, ...]) -> bool:
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in names


def test_the_walk_sees_the_packages():
    files = [_rel(p) for p, _ in _modules()]
    assert len(files) > 100 and DECLARATION_MODULE in files


def test_plug_ins_are_not_probed_by_name():
    found = []
    for path, tree in _modules():
        if _rel(path) == DECLARATION_MODULE:
            continue
        for node in ast.walk(tree):
            if _called(node, ("getattr", "hasattr")) and node.args:  # type: ignore[attr-defined]
                target = ast.unparse(node.args[0])  # type: ignore[attr-defined]
                if (path.name, target) not in ALLOWED_PROBES:
                    found.append(f"{_rel(path)}:{node.lineno}: {ast.unparse(node)}")
    assert found == [], f"ask through a declaration (track_envs.infra.declared), or allow-list: {found}"


def _protocols(trees: list[ast.Module]) -> set[str]:
    """Names of the project's Protocol classes (subclasses of Protocol, to a fixed point)."""
    classes = [n for tree in trees for n in ast.walk(tree) if isinstance(n, ast.ClassDef)]
    protocols = {"Protocol"}
    while True:
        more = {
            c.name
            for c in classes
            if any(ast.unparse(b).rpartition(".")[2] in protocols for b in c.bases)
            and c.name not in protocols
        }
        if not more:
            return protocols - {"Protocol"}
        protocols |= more


def test_no_runtime_protocol_checks():
    modules = list(_modules())
    protocols = _protocols([tree for _, tree in modules])
    assert {"Predictor", "Agent", "DisplacementModel", "CommonDisplacementModel", "PoseMotion"} <= protocols
    found = []
    for path, tree in modules:
        for node in ast.walk(tree):
            if _called(node, ("isinstance", "issubclass")) and len(node.args) == 2:  # type: ignore[attr-defined]
                kinds = node.args[1]  # type: ignore[attr-defined]
                names = kinds.elts if isinstance(kinds, ast.Tuple) else [kinds]
                if any(ast.unparse(n).rpartition(".")[2] in protocols for n in names):
                    found.append(f"{_rel(path)}:{node.lineno}: {ast.unparse(node)}")
    assert found == [], f"ask through a declaration (track_envs.infra.declared), not a protocol: {found}"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _private_import_problems(path: Path, node: ast.ImportFrom) -> list[str]:
    """What breaks the private-import rule (module docstring) in one ``from ... import``."""
    here = _module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    parts = node.module.split(".") if node.module else []

    def inside(owner: str) -> bool:
        return package == owner or package.startswith(owner + ".")

    def module_allowed(module: list[str]) -> bool:
        first = next(i for i, p in enumerate(module) if _private(p))
        if module[first] == "_kernels":
            return inside(module[0])
        return inside(".".join(module[:first]))

    out = []
    if any(_private(p) for p in parts) and not module_allowed(parts):
        out.append(f"from {node.module} import ...")
    for alias in node.names:
        if not _private(alias.name) or (path.name, alias.name) in ALLOWED_PRIVATE_IMPORTS:
            continue
        module_file = ROOT / Path(*parts) / f"{alias.name}.py"  # a private module of a package
        if module_file.exists() and module_allowed([*parts, alias.name]):
            continue
        out.append(f"from {node.module} import {alias.name}")
    return out


def test_no_private_names_are_imported_across_modules():
    found = [
        f"{_rel(path)}:{node.lineno}: {problem}"
        for path, tree in _modules()
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.module is not None and not node.level
        for problem in _private_import_problems(path, node)
    ]
    assert found == [], found


@pytest.mark.parametrize("source", ["getattr(model, 'displacement', None)", "hasattr(agent, 'warm_up')"])
def test_the_probe_check_sees_a_probe(source):
    tree = ast.parse(source)
    assert any(_called(n, ("getattr", "hasattr")) for n in ast.walk(tree))
