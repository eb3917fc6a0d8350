"""The one model-file format: round trip and the errors a bad file gives."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from predictors.training.model_file import (
    ModelFile,
    ModelFileError,
    load_model,
    model_paths,
    require_shapes,
    save_model,
)


def _model(kind: str = "nll-lstm", dim: int = 2) -> ModelFile:
    rng = np.random.default_rng(0)
    return ModelFile(
        kind=kind,
        dim=dim,
        architecture={"hidden": [3, 2]},
        tensors={"a.weight": rng.normal(size=(4, 3)).astype(np.float32), "a.bias": np.zeros(4, np.float32)},
        meta={"normalisation": {"low": [0.0, 0.0]}, "training": {"command": "track-train nll-lstm"}},
    )


def test_round_trip_keeps_tensors_and_sidecar(tmp_path: Path) -> None:
    tensor_path, sidecar_path = save_model(tmp_path / "m", _model())
    assert tensor_path.name == "m.safetensors" and sidecar_path.name == "m.json"
    for name in ("m", "m.json", "m.safetensors"):
        loaded = load_model(tmp_path / name, kind="nll-lstm", dim=2)
        assert loaded.kind == "nll-lstm" and loaded.dim == 2
        np.testing.assert_array_equal(loaded.tensors["a.weight"], _model().tensors["a.weight"])
        assert loaded.meta["training"]["command"] == "track-train nll-lstm"
        assert loaded.path == sidecar_path


def test_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match=r"m\.json does not exist"):
        load_model(tmp_path / "m")


def test_corrupt_weights_are_named(tmp_path: Path) -> None:
    tensor_path, _ = save_model(tmp_path / "m", _model())
    tensor_path.write_bytes(b"not a safetensors file")
    with pytest.raises(ModelFileError, match=r"m\.safetensors are corrupt"):
        load_model(tmp_path / "m")


def test_corrupt_sidecar_is_named(tmp_path: Path) -> None:
    _, sidecar_path = save_model(tmp_path / "m", _model())
    sidecar_path.write_text("{not json")
    with pytest.raises(ModelFileError, match=r"m\.json is not valid JSON"):
        load_model(tmp_path / "m")


def test_other_kind_and_dimension_are_refused(tmp_path: Path) -> None:
    save_model(tmp_path / "m", _model(kind="lstm", dim=3))
    with pytest.raises(ModelFileError, match=r"holds a 'lstm' model; expected 'nll-lstm'"):
        load_model(tmp_path / "m", kind="nll-lstm")
    with pytest.raises(ModelFileError, match=r"dimension 3; expected 2"):
        load_model(tmp_path / "m", dim=2)


def test_tensor_shape_mismatch_with_sidecar(tmp_path: Path) -> None:
    _, sidecar_path = save_model(tmp_path / "m", _model())
    sidecar = json.loads(sidecar_path.read_text())
    sidecar["tensors"]["a.weight"] = [5, 3]
    sidecar_path.write_text(json.dumps(sidecar))
    with pytest.raises(ModelFileError, match=r"'a.weight' has shape \(4, 3\), m\.json says \(5, 3\)"):
        load_model(tmp_path / "m")


def test_require_shapes_names_the_tensor(tmp_path: Path) -> None:
    save_model(tmp_path / "m", _model())
    model = load_model(tmp_path / "m")
    require_shapes(model, {"a.weight": (4, 3)})
    with pytest.raises(
        ModelFileError, match=r"'a.weight' has shape \(4, 3\), the architecture needs \(8, 3\)"
    ):
        require_shapes(model, {"a.weight": (8, 3)})


def test_model_paths_strip_either_suffix() -> None:
    assert model_paths("w/x.json") == model_paths("w/x.safetensors") == model_paths("w/x")


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_both_files_get_the_permissions_of_any_new_file(tmp_path: Path, umask: int) -> None:
    import os
    import stat

    old = os.umask(umask)
    try:
        tensor_path, sidecar_path = save_model(tmp_path / "m", _model())
        (tmp_path / "plain.txt").write_text("x")
    finally:
        os.umask(old)
    modes = {stat.S_IMODE(p.stat().st_mode) for p in (tensor_path, sidecar_path, tmp_path / "plain.txt")}
    assert modes == {0o666 & ~umask}
