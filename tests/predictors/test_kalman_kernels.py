"""The compiled Kalman kernels against filterpy (one ``KalmanFilter`` per track) and a textbook
numpy reference, on random batches and edge cases; the public wrappers on odd inputs.

Same scale-free tolerance as ``test_kalman.py`` (``TOL = 1e-9``, relative to the reference
standard deviations).
"""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from numpy.typing import NDArray
from test_kalman import assert_gaussian_close  # the filterpy comparison's tolerance check

from predictors.kalman import _kernels as kernels
from predictors.kalman.predictor import (
    ca_model,
    cv_model,
    kf_predict,
    kf_update,
    measurement_prediction,
    random_walk_model,
)

MODELS = {"cv": cv_model, "ca": ca_model, "random-walk": random_walk_model}
# (model, D): planar CV and CA (compiled with constant sizes), and the generic path: random walk,
# 3-D CV and CA, 1-D
SHAPES = [("cv", 2), ("ca", 2), ("random-walk", 2), ("cv", 3), ("ca", 3), ("random-walk", 1)]


def random_batch(rng: np.random.Generator, model: str, dim: int, n: int) -> tuple[NDArray[np.float64], ...]:
    """Model matrices at belt scale and ``n`` random tracks with SPD covariances."""
    F, Q, H = MODELS[model](dim, 0.01, 1.0)
    S = F.shape[0]
    a = rng.normal(size=(n, S, S))
    cov = (a @ np.swapaxes(a, 1, 2)) * 1e-6 + np.eye(S) * 1e-8
    cov = 0.5 * (cov + np.swapaxes(cov, 1, 2))  # exactly symmetric
    mean = rng.normal(size=(n, S))
    R = np.eye(dim) * 1e-8
    z = mean[:, :dim] + rng.normal(scale=1e-3, size=(n, dim))
    return F, Q, H, R, mean, cov, z


def filterpy_filters(
    F: NDArray[np.float64],
    Q: NDArray[np.float64],
    H: NDArray[np.float64],
    R: NDArray[np.float64],
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
) -> list[KalmanFilter]:
    filters = []
    for x, P in zip(mean, cov, strict=True):
        kf = KalmanFilter(dim_x=F.shape[0], dim_z=H.shape[0])
        kf.F, kf.Q, kf.H, kf.R = F.copy(), Q.copy(), H.copy(), R.copy()
        kf.x, kf.P = x.reshape(-1, 1).copy(), P.copy()
        filters.append(kf)
    return filters


def stacked(filters: list[KalmanFilter], S: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    mean = np.array([kf.x[:, 0] for kf in filters]).reshape(-1, S)
    cov = np.array([kf.P for kf in filters]).reshape(-1, S, S)
    return mean, cov


@pytest.mark.parametrize("n", [0, 1, 23])
@pytest.mark.parametrize(("model", "dim"), SHAPES)
def test_kernels_match_filterpy_on_random_batches(model: str, dim: int, n: int) -> None:
    rng = np.random.default_rng(SHAPES.index((model, dim)) * 10 + n)
    F, Q, H, R, mean, cov, z = random_batch(rng, model, dim, n)
    S = F.shape[0]
    filters = filterpy_filters(F, Q, H, R, mean, cov)

    mean_p, cov_p, z_mean, z_cov = kernels.predict_and_project_tracks(mean, cov, F, Q, H, R)
    for kf in filters:
        kf.predict()
    ref_mean, ref_cov = stacked(filters, S)
    assert mean_p.shape == (n, S) and cov_p.shape == (n, S, S)
    assert_gaussian_close(mean_p, cov_p, ref_mean, ref_cov, "predict")
    assert_gaussian_close(z_mean, z_cov, ref_mean @ H.T, H @ ref_cov @ H.T + R, "predicted measurement")
    np.testing.assert_array_equal(cov_p, np.swapaxes(cov_p, 1, 2))
    np.testing.assert_array_equal(z_cov, np.swapaxes(z_cov, 1, 2))

    seen = rng.random(n) < 0.6
    z[~seen] = np.nan  # never read
    mean_u, cov_u, status, row = kernels.update_tracks(mean_p, cov_p, z, seen, H, R)
    assert (status, row) == (kernels.UPDATE_OK, -1)
    for kf, zi, s in zip(filters, z, seen, strict=True):
        if s:
            kf.update(zi.reshape(-1, 1))
    ref_mean, ref_cov = stacked(filters, S)
    assert_gaussian_close(mean_u, cov_u, ref_mean, ref_cov, "update")
    np.testing.assert_array_equal(mean_u[~seen], mean_p[~seen])
    np.testing.assert_array_equal(cov_u[~seen], cov_p[~seen])
    np.testing.assert_array_equal(cov_u, np.swapaxes(cov_u, 1, 2))


@pytest.mark.parametrize(("model", "dim"), SHAPES)
def test_kernels_match_the_textbook_formulas(model: str, dim: int) -> None:
    rng = np.random.default_rng(100 + SHAPES.index((model, dim)))
    F, Q, H, R, mean, cov, z = random_batch(rng, model, dim, 9)
    mean_p, cov_p = kernels.predict_tracks(mean, cov, F, Q)
    assert_gaussian_close(mean_p, cov_p, mean @ F.T, F @ cov @ F.T + Q, "predict")
    z_mean, z_cov = kernels.project_tracks(mean_p, cov_p, H, R)
    assert_gaussian_close(z_mean, z_cov, mean_p @ H.T, H @ cov_p @ H.T + R, "project")

    mean_u, cov_u, status, _ = kernels.update_tracks(mean_p, cov_p, z, np.ones(9, dtype=bool), H, R)
    assert status == kernels.UPDATE_OK
    eye = np.eye(F.shape[0])
    for i in range(9):
        P = cov_p[i]
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        A = eye - K @ H
        ref_P = A @ P @ A.T + K @ R @ K.T  # Joseph form
        ref_x = mean_p[i] + K @ (z[i] - H @ mean_p[i])
        assert_gaussian_close(mean_u[i], cov_u[i], ref_x, ref_P, f"update row {i}")


def test_update_with_nothing_seen_copies_the_state() -> None:
    _, _, H, R, mean, cov, z = random_batch(np.random.default_rng(0), "ca", 2, 5)
    z[:] = np.nan
    mean_u, cov_u, status, _ = kernels.update_tracks(mean, cov, z, np.zeros(5, dtype=bool), H, R)
    assert status == kernels.UPDATE_OK
    np.testing.assert_array_equal(mean_u, mean)
    np.testing.assert_array_equal(cov_u, cov)
    assert not np.shares_memory(mean_u, mean) and not np.shares_memory(cov_u, cov)


def test_update_reports_the_offending_row() -> None:
    _, _, H, R, mean, cov, z = random_batch(np.random.default_rng(1), "cv", 2, 4)
    seen = np.array([True, False, True, True])
    bad_z = z.copy()
    bad_z[2, 1] = np.inf
    assert kernels.update_tracks(mean, cov, bad_z, seen, H, R)[2:] == (kernels.UPDATE_NONFINITE_Z, 2)
    bad_cov = cov.copy()
    bad_cov[3, :2, :2] = -np.eye(2)  # S = H P Hᵀ + R not positive definite
    assert kernels.update_tracks(mean, bad_cov, z, seen, H, R)[2:] == (kernels.UPDATE_NOT_PD, 3)
    seen[3] = False  # an unseen track is never factorised
    assert kernels.update_tracks(mean, bad_cov, z, seen, H, R)[2:] == (kernels.UPDATE_OK, -1)


def test_public_functions_accept_any_layout_and_raise_on_bad_rows() -> None:
    F, Q, H, R, mean, cov, z = random_batch(np.random.default_rng(2), "ca", 2, 6)
    F32 = F.astype(np.float32)
    ref = kf_predict(mean, cov, F32.astype(np.float64), Q)
    # Fortran order, transposed views and float32 give the results of C-contiguous float64
    odd = kf_predict(np.asfortranarray(mean), cov.transpose(0, 2, 1), F32, Q)
    np.testing.assert_array_equal(odd[0], ref[0])
    np.testing.assert_array_equal(odd[1], ref[1])
    upd = kf_update(ref[0][::2], ref[1][::2], z[::2], H, R)
    upd_c = kf_update(ref[0][::2].copy(), ref[1][::2].copy(), z[::2].copy(), H, R)
    np.testing.assert_array_equal(upd[0], upd_c[0])
    np.testing.assert_array_equal(upd[1], upd_c[1])
    gauss = measurement_prediction(ref[0], ref[1], H, R)
    assert gauss.mean.shape == (6, 2) and gauss.cov.shape == (6, 2, 2)
    z[4] = np.nan
    with pytest.raises(ValueError, match="row 4"):
        kf_update(ref[0], ref[1], z, H, R)
    with pytest.raises(np.linalg.LinAlgError, match="track 0 is not positive definite"):
        kf_update(ref[0][:1], -ref[1][:1], z[:1], H, R)


def test_public_functions_name_disagreeing_shapes() -> None:
    F, Q, H, R, mean, cov, z = random_batch(np.random.default_rng(3), "cv", 2, 3)
    with pytest.raises(ValueError, match=r"mean must be \(n, S\) and cov \(n, S, S\)"):
        kf_predict(mean, cov[:2], F, Q)
    with pytest.raises(ValueError, match=r"F must have shape \(4, 4\) for S=4, got \(6, 6\)"):
        kf_predict(mean, cov, np.eye(6), Q)
    with pytest.raises(ValueError, match=r"z must have shape \(3, 2\), got \(2, 2\)"):
        kf_update(mean, cov, z[:2], H, R)
    with pytest.raises(ValueError, match=r"R must have shape \(2, 2\)"):
        measurement_prediction(mean, cov, H, np.eye(3))
