"""SingleTargetError: mean error, RMSE, lost, occlusion error, empty reports."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.contracts.report import empty_report
from track_envs.metrics import Metric
from track_envs.metrics.single_target import SingleTargetError


def truth_at(x, y):
    return {
        "ids": np.array([0, -1]),
        "positions": np.array([[x, y], [0.0, 0.0]]),
        "visible": np.array([1, 0], bool),
    }


def report_at(*points):
    r = empty_report(3, (2,))
    for i, p in enumerate(points):
        r["mask"][i] = 1
        r["positions"][i] = p
    return r


NO_DETS = np.full(4, -1, dtype=np.int64)


def test_mean_rmse_and_occlusion_error():
    m = SingleTargetError(occlusion=(1, 3))
    assert isinstance(m, Metric)
    errors = [3.0, 4.0, 0.0, 1.0]
    for e in errors:
        m.update(truth_at(0.0, 0.0), NO_DETS, report_at((e, 0.0), (100.0, 100.0)))  # first row counts
    out = m.compute()
    assert out["mean_error"] == pytest.approx(2.0)
    assert out["rmse"] == pytest.approx(np.sqrt(np.mean(np.square(errors))))
    assert out["occlusion_error"] == pytest.approx(2.0)
    assert out["lost"] == 0.0 and out["frames_without_estimate"] == 0.0


def test_lost_above_five_and_nan_occlusion_when_empty():
    m = SingleTargetError()
    m.update(truth_at(0.0, 0.0), NO_DETS, report_at((6.0, 0.0)))
    out = m.compute()
    assert out["lost"] == 1.0 and np.isnan(out["occlusion_error"])


def test_empty_report_holds_the_last_position_and_early_frames_are_skipped():
    m = SingleTargetError()
    m.update(truth_at(0.0, 0.0), NO_DETS, report_at())  # no estimate yet: skipped
    m.update(truth_at(1.0, 0.0), NO_DETS, report_at((1.0, 0.0)))
    m.update(truth_at(2.0, 0.0), NO_DETS, report_at())  # holds (1, 0): error 1
    out = m.compute()
    assert out["mean_error"] == pytest.approx(0.5)
    assert out["frames_without_estimate"] == 1.0


def test_no_estimate_at_all_is_lost_and_reset_forgets():
    m = SingleTargetError()
    m.update(truth_at(0.0, 0.0), NO_DETS, report_at())
    out = m.compute()
    assert np.isnan(out["mean_error"]) and out["lost"] == 1.0
    m.reset()
    m.update(truth_at(0.0, 0.0), NO_DETS, report_at((0.0, 0.0)))
    assert m.compute()["mean_error"] == 0.0 and m.compute()["frames_without_estimate"] == 0.0


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="occlusion"):
        SingleTargetError(occlusion=(5, 2))
    with pytest.raises(ValueError, match="lost_threshold"):
        SingleTargetError(lost_threshold=-1.0)
