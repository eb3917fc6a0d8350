"""The streaming GOSPA is the mean of per-frame ``gospa`` calls on the visible truth."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.metrics import GospaMetric, Metric
from track_envs.metrics.gospa import gospa


def test_streaming_gospa_is_the_mean_of_per_frame_gospa():
    rng = np.random.default_rng(0)
    metric = GospaMetric(c=3.0)
    assert isinstance(metric, Metric)
    per_frame = []
    for _ in range(50):
        m, n = rng.integers(0, 6, size=2)
        ids = np.full(8, -1, np.int64)
        ids[:m] = rng.permutation(100)[:m]
        positions = rng.uniform(0, 10, size=(8, 2))
        visible = rng.random(8) < 0.8
        mask = np.zeros(6, np.int8)
        mask[rng.permutation(6)[:n]] = 1
        report: dict[str, np.ndarray] = {
            "ids": rng.integers(0, 5, 6),
            "positions": rng.uniform(0, 10, size=(6, 2)).astype(np.float32),
            "detection": np.full(6, -1, np.int64),
            "mask": mask,
        }
        metric.update({"ids": ids, "positions": positions, "visible": visible}, np.full(4, -1), report)
        live = (ids >= 0) & visible
        per_frame.append(gospa(positions[live], report["positions"][mask == 1].astype(np.float64), 3.0))
    out = metric.compute()
    assert out["gospa"] == pytest.approx(np.mean([r.distance for r in per_frame]), rel=1e-12)
    assert out["gospa_localisation"] == pytest.approx(np.mean([r.localisation for r in per_frame]), rel=1e-12)
    assert out["gospa_missed"] == pytest.approx(np.mean([r.missed for r in per_frame]))
    assert out["gospa_false"] == pytest.approx(np.mean([r.false for r in per_frame]))
    assert out["n_frames"] == 50.0
    metric.reset()
    assert np.isnan(metric.compute()["gospa"])
    with pytest.raises(ValueError, match="cut-off"):
        GospaMetric(c=0.0)


def test_reports_that_are_not_points_are_rejected():
    truth = {"ids": np.arange(3), "positions": np.zeros((3, 2)), "visible": np.ones(3, bool)}
    report: dict[str, np.ndarray] = {
        "ids": np.arange(2),
        "positions": np.zeros((2, 17, 2)),
        "detection": np.full(2, -1),
        "mask": np.ones(2, np.int8),
    }
    with pytest.raises(ValueError, match=r"point reports .*\(2, 17, 2\)"):
        GospaMetric(c=1.0).update(truth, np.full(4, -1), report)
