"""The Kalman predictors' measurement-noise scale (set_noise_scale)."""

from __future__ import annotations

import numpy as np
import pytest

from predictors.kalman.predictor import R_FLOOR, KalmanPredictor
from track_envs.values.types import SensorSpec

SPEC = SensorSpec(
    dt=0.01,
    dim=2,
    noise_std=1e-4,
    p_detect=1.0,
    clutter_rate=0.0,
    region_low=(0.0, 0.0),
    region_high=(1.0, 1.0),
    max_detections=4,
    max_tracks=4,
)


@pytest.mark.parametrize("model", ["cv", "ca", "random-walk"])
def test_scale_sets_r_and_the_start_covariance(model):
    kf = KalmanPredictor(model)
    kf.set_noise_scale(4.0)  # before reset: kept
    kf.reset(SPEC)
    np.testing.assert_allclose(kf.R, (4e-4) ** 2 * np.eye(2))
    state = kf.start(np.zeros((1, 2)))
    np.testing.assert_allclose(kf.estimate(state).cov[0], (4e-4) ** 2 * np.eye(2))
    _, pred = kf.predict(state)
    kf.set_noise_scale(1.0)
    _, plain = kf.predict(state)
    np.testing.assert_allclose(pred.cov - plain.cov, ((4e-4) ** 2 - (1e-4) ** 2) * np.eye(2)[None], rtol=1e-9)


def test_the_floor_still_holds_for_a_tiny_scale():
    kf = KalmanPredictor("cv")
    kf.reset(SPEC)
    kf.set_noise_scale(1e-9)
    np.testing.assert_array_equal(kf.R, R_FLOOR * np.eye(2))


@pytest.mark.parametrize("scale", [0.0, -1.0, float("inf"), float("nan"), True, "2"])
def test_bad_scales_are_refused(scale):
    kf = KalmanPredictor("cv")
    with pytest.raises(ValueError, match="noise scale must be a finite number > 0"):
        kf.set_noise_scale(scale)
    assert kf.noise_scale == 1.0
