"""The ray engine against a real local Ray instance: same seeds, same metrics as the local engine."""

from __future__ import annotations

from typing import Any

import pytest

from track_apps.bench import load_records, run_cells

ray = pytest.importorskip("ray", reason='the ray engine needs pip install "track-envs[ray]"')


def metrics_by_key(records: list[dict[str, Any]]) -> dict[str, dict[str, str]]:
    """Cell key → metrics as reprs (NaN equals NaN; floats compared bit for bit)."""
    return {r["key"]: {k: repr(float(v)) for k, v in r["metrics"].items()} for r in records}


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def test_ray_equals_local_engines(tmp_path, small_cells, local_ray):
    ray_run = run_cells(small_cells, tmp_path / "ray", engine="ray", progress=False)
    assert ray_run.computed == len(small_cells)
    assert local_ray.is_initialized()  # the engine leaves a Ray it did not start running
    run_cells(small_cells, tmp_path / "one", workers=1, progress=False)
    run_cells(small_cells, tmp_path / "two", workers=2, progress=False)
    by_ray = metrics_by_key(load_records(tmp_path / "ray"))
    assert by_ray == metrics_by_key(load_records(tmp_path / "one"))
    assert by_ray == metrics_by_key(load_records(tmp_path / "two"))
    rerun = run_cells(small_cells, tmp_path / "ray", engine="ray", progress=False)
    assert rerun.computed == 0
