"""Compiled kernels with three or more results return their documented named tuples."""

from __future__ import annotations

import numpy as np
import pytest

from agents.tracking import _kernels as tracking
from agents.tracking import _upkeep_kernels as gnn
from predictors.kalman import _kernels as kalman
from predictors.kalman.predictor import cv_model


def _tracks(n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    mean = rng.uniform(0.0, 1.0, size=(n, 2))
    cov = np.broadcast_to(np.eye(2) * 1e-2, (n, 2, 2)).copy()
    return mean, cov


def _kalman_tracks(n: int):
    F, Q, H = cv_model(2, 0.01, 1.0)
    R = np.eye(2) * 1e-4
    mean = np.zeros((n, 4))
    mean[:, :2] = np.arange(2 * n, dtype=float).reshape(n, 2)
    cov = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    return mean, cov, F, Q, H, R


def _gnn_results() -> list[tuple[object, type]]:
    mean, cov = _tracks(3)
    det = np.array([0, -1, -1], dtype=np.int64)
    counters = np.zeros(3, dtype=np.int64)
    z = mean[[0, 2]] + 1e-3
    lo, hi = np.zeros(2), np.ones(2)
    upkeep = gnn.frame_upkeep(det, counters, counters, mean, lo, hi, 2, (3, 6), 2)
    flow = gnn.learn_flow(np.zeros((8, 2)), 0, 0, 0, mean, mean - 0.01, upkeep.seen, 0.01, 1)
    recovery = gnn.recovery_costs(mean, cov, z, det, 4.0, 9.0, mean, 0.0, 3.0, 1e-3)
    arrays = gnn.survivors_and_births(
        upkeep.keep, upkeep.n_keep, np.arange(3), counters, counters, mean, det, z[:1], np.array([1]), 3
    )
    return [
        (upkeep, gnn.FrameUpkeep),
        (flow, gnn.FlowUpdate),
        (recovery, gnn.RecoveryCosts),
        (arrays, gnn.TrackArrays),
    ]


def _tracking_results() -> list[tuple[object, type]]:
    mean, cov = _tracks(3)
    return [(tracking.gated_pairs(mean, cov, mean[::-1].copy(), 9.0), tracking.GatedPairs)]


def _kalman_results() -> list[tuple[object, type]]:
    mean, cov, F, Q, H, R = _kalman_tracks(3)
    predicted = kalman.predict_and_project_tracks(mean, cov, F, Q, H, R)
    seen = np.array([True, False, True])
    updated = kalman.update_tracks(predicted.mean, predicted.cov, predicted.z_mean, seen, H, R)
    P0 = np.eye(4)
    kept = kalman.keep_and_start_tracks(
        mean, cov, seen, 2, np.ones((1, 2)), P0, np.zeros(0), np.zeros((0, 0))
    )
    return [
        (predicted, kalman.PredictedTracks),
        (updated, kalman.UpdatedTracks),
        (kept, kalman.KeptAndStarted),
    ]


@pytest.mark.parametrize("results", [_gnn_results, _tracking_results, _kalman_results])
def test_kernels_return_their_named_tuples(results):
    for result, kind in results():
        assert issubclass(kind, tuple) and hasattr(kind, "_fields")
        assert type(result) is kind, (type(result), kind)
        assert len(result) == len(kind._fields) >= 3
        for position, field in enumerate(kind._fields):
            assert getattr(result, field) is result[position]
        assert kind.__doc__ and all(f"{field}:" in kind.__doc__ for field in kind._fields)


def test_kernel_results_are_read_by_name():
    mean, cov, F, Q, H, R = _kalman_tracks(2)
    predicted = kalman.predict_and_project_tracks(mean, cov, F, Q, H, R)
    state_mean, state_cov = kalman.predict_tracks(mean, cov, F, Q)
    np.testing.assert_array_equal(predicted.mean, state_mean)
    np.testing.assert_array_equal(predicted.cov, state_cov)
    np.testing.assert_array_equal(predicted.z_mean, state_mean[:, :2])
    bad = kalman.update_tracks(mean, cov, np.full((2, 2), np.nan), np.ones(2, dtype=bool), H, R)
    assert (bad.status, bad.row) == (kalman.UPDATE_NONFINITE_Z, 0)
