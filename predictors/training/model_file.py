"""One file format for every learned model: ``NAME.safetensors`` (tensors) + ``NAME.json`` (sidecar).

The tensors are stored with `safetensors <https://github.com/huggingface/safetensors>`_ (no pickles:
loading a model file never runs code); the JSON sidecar holds everything else a model needs to be
used and trusted:

``format``
    ``"track-envs-model"``, and ``format_version`` (an integer; bumped on incompatible changes);
``kind``
    the model family, e.g. ``"nll-lstm"``; a loader for one kind refuses another;
``dim``
    the measurement dimension ``D`` the model consumes and predicts;
``architecture``
    the hyper-parameters that fix the tensor shapes (layer sizes, dropout rate, ...);
``tensors``
    the expected shape of every stored tensor, checked on load against the safetensors file;
``normalisation``, ``calibration``, ``training``, ``data``, ``metrics``, ``versions``
    free-form mappings written by the training command (input scaling, the calibration factor,
    the exact command line and its wall time, the data description, test-split metrics, package
    versions).

Use [`save_model`][predictors.training.save_model] and [`load_model`][predictors.training.load_model]; both
take the path with or without a suffix (``weights/nll-lstm``, ``weights/nll-lstm.json`` and
``weights/nll-lstm.safetensors`` name the same model). Every problem on load raises
[`ModelFileError`][predictors.training.ModelFileError] naming the file and what is wrong: a missing file, a
corrupt one, another kind, another dimension or a tensor whose shape does not match the sidecar.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.atomic import write_bytes, write_text

#: Value of the sidecar's ``format`` key.
FORMAT = "track-envs-model"
#: Current sidecar format version.
FORMAT_VERSION = 1


class ModelFileError(ValueError):
    """A model file is missing, corrupt, or does not match what the loader expects."""


@dataclass(frozen=True)
class ModelFile:
    """A learned model as stored on disk.

    Attributes:
        kind: Model family (``"lstm"``, ``"nll-lstm"``, ...).
        dim: Measurement dimension ``D``.
        architecture: Hyper-parameters that fix the tensor shapes.
        tensors: Named float arrays (the weights).
        meta: Every other sidecar entry (normalisation, calibration, training, data, metrics, versions).
        path: The sidecar path this model was loaded from (``None`` for a model built in memory).
    """

    kind: str
    dim: int
    architecture: Mapping[str, Any]
    tensors: Mapping[str, NDArray[np.float32]] = field(repr=False)
    meta: Mapping[str, Any] = field(default_factory=dict)
    path: Path | None = None


def model_paths(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The ``(tensors, sidecar)`` paths of the model named by ``path`` (suffix optional)."""
    p = Path(path)
    if p.suffix in (".json", ".safetensors"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".safetensors"), p.with_name(p.name + ".json")


def save_model(path: str | os.PathLike[str], model: ModelFile) -> tuple[Path, Path]:
    """Write ``model`` as ``path.safetensors`` + ``path.json``; return both paths.

    The sidecar records each tensor's shape, so a loader can check the weights before using them.
    Both files are written as any file is (permissions from the umask, e.g. 0644): the tensors are
    serialised in memory and each file is written atomically
    (`track_envs.infra.atomic`: a temporary file beside it, renamed; a failed write
    leaves the old model), not with safetensors' ``save_file`` (a private 0600 file).
    """
    from safetensors.numpy import save

    tensor_path, sidecar_path = model_paths(path)
    tensor_path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {name: np.ascontiguousarray(value, dtype=np.float32) for name, value in model.tensors.items()}
    sidecar = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": model.kind,
        "dim": int(model.dim),
        "architecture": dict(model.architecture),
        "tensors": {name: list(a.shape) for name, a in arrays.items()},
        **{k: v for k, v in model.meta.items() if k not in _RESERVED},
    }
    write_bytes(tensor_path, save(arrays, metadata={"kind": model.kind}))
    write_text(sidecar_path, json.dumps(sidecar, indent=2, sort_keys=False, default=_json_default) + "\n")
    return tensor_path, sidecar_path


_RESERVED = ("format", "format_version", "kind", "dim", "architecture", "tensors")


def load_model(
    path: str | os.PathLike[str], *, kind: str | tuple[str, ...] | None = None, dim: int | None = None
) -> ModelFile:
    """Read and validate the model named by ``path``.

    Args:
        path: The model's name, with or without ``.json`` / ``.safetensors``.
        kind: The kind (or kinds) the caller can use; another raises
            [`ModelFileError`][predictors.training.ModelFileError].
        dim: The measurement dimension the caller needs; another raises
            [`ModelFileError`][predictors.training.ModelFileError].

    Raises:
        ModelFileError: naming the file and the problem (missing, corrupt, kind, dimension, shapes).
    """
    from safetensors import SafetensorError
    from safetensors.numpy import load_file

    tensor_path, sidecar_path = model_paths(path)
    for p in (sidecar_path, tensor_path):
        if not p.is_file():
            raise ModelFileError(f"model file {p} does not exist")
    try:
        sidecar = json.loads(sidecar_path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"model sidecar {sidecar_path} is not valid JSON: {exc}") from None
    if not isinstance(sidecar, dict) or sidecar.get("format") != FORMAT:
        raise ModelFileError(f"{sidecar_path} is not a track-envs model sidecar (no 'format': {FORMAT!r})")
    if sidecar.get("format_version") != FORMAT_VERSION:
        raise ModelFileError(
            f"{sidecar_path} has format_version {sidecar.get('format_version')!r}; "
            f"this version reads {FORMAT_VERSION}"
        )
    for key in ("kind", "dim", "architecture", "tensors"):
        if key not in sidecar:
            raise ModelFileError(f"{sidecar_path} lacks the key {key!r}")
    kinds = (kind,) if isinstance(kind, str) else kind
    if kinds is not None and sidecar["kind"] not in kinds:
        raise ModelFileError(
            f"{sidecar_path} holds a {sidecar['kind']!r} model; expected {' or '.join(map(repr, kinds))}"
        )
    if dim is not None and sidecar["dim"] != dim:
        raise ModelFileError(f"{sidecar_path} holds a model of dimension {sidecar['dim']}; expected {dim}")
    try:
        tensors = load_file(str(tensor_path))
    except (SafetensorError, OSError, ValueError) as exc:
        raise ModelFileError(f"model weights {tensor_path} are corrupt: {exc}") from None
    expected = {name: tuple(shape) for name, shape in sidecar["tensors"].items()}
    missing = sorted(set(expected) - set(tensors))
    extra = sorted(set(tensors) - set(expected))
    if missing or extra:
        raise ModelFileError(
            f"{tensor_path}: tensors {missing} missing and {extra} not in {sidecar_path.name}"
        )
    for name, shape in expected.items():
        if tensors[name].shape != shape:
            raise ModelFileError(
                f"{tensor_path}: tensor {name!r} has shape {tensors[name].shape}, "
                f"{sidecar_path.name} says {shape}"
            )
    meta = {k: v for k, v in sidecar.items() if k not in _RESERVED}
    return ModelFile(
        kind=sidecar["kind"],
        dim=int(sidecar["dim"]),
        architecture=sidecar["architecture"],
        tensors=tensors,
        meta=meta,
        path=sidecar_path,
    )


def require_shapes(model: ModelFile, shapes: Mapping[str, tuple[int, ...]]) -> None:
    """Check that ``model`` has a tensor of each given shape (what its architecture implies).

    Raises:
        ModelFileError: naming the file, the tensor and both shapes.
    """
    where = model.path or f"<{model.kind} model>"
    for name, shape in shapes.items():
        if name not in model.tensors:
            raise ModelFileError(f"{where}: tensor {name!r} is missing")
        if tuple(model.tensors[name].shape) != tuple(shape):
            raise ModelFileError(
                f"{where}: tensor {name!r} has shape {tuple(model.tensors[name].shape)}, "
                f"the architecture needs {tuple(shape)}"
            )


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot store {type(value).__name__} in a model sidecar")
