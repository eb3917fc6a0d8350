"""Tracker-side prediction metrics: mean absolute prediction error, NEES and reliability curves.

These score a predictor's predicted measurement distribution against what then happened, so they
take explicit arrays (``update(mean, cov, target)``), not the report.

* Mean absolute prediction error per track (Pollithy et al. 2020, Sec. V): for track
  ``k`` with predictions ``ŷ_{k,t}`` and the measurements ``y_{k,t}`` it was then updated with,
  ``MAE_k = mean_t ||ŷ_{k,t} − y_{k,t}||_2``; the score is the average of ``MAE_k`` over tracks.
* NEES (normalised estimation error squared; Bar-Shalom, Li, Kirubarajan, "Estimation with
  Applications to Tracking and Navigation", 2001, Sec. 5.4): with
  ``d_i² = (y_i − μ_i)ᵀ Σ_i⁻¹ (y_i − μ_i)``, ``NEES = mean_i d_i² / D`` (≈ 1 when calibrated,
  since ``d²`` is χ²-distributed with ``D`` degrees of freedom).
* Reliability curve (Pollithy et al. 2020, Sec. IV-E; Kuleshov, Fenner, Ermon, "Accurate Uncertainties for
  Deep Learning Using Calibrated Regression", ICML 2018): for each expected confidence level
  ``p``, the empirical level ``p_emp(p) = mean_i 1{d_i² ≤ F⁻¹_{χ²_D}(p)}``; calibrated
  predictions lie on the diagonal. The calibration error is ``mean_p |p_emp(p) − p|``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

DEFAULT_LEVELS = np.append(np.round(np.arange(1, 20) * 0.05, 10), 0.999)


def mahalanobis_sq(mean: ArrayLike, cov: ArrayLike, target: ArrayLike) -> NDArray[np.float64]:
    """Squared Mahalanobis distances ``(y − μ)ᵀ Σ⁻¹ (y − μ)`` of ``target`` (n, D) under N(mean, cov).

    Args:
        mean: Predicted means, (n, D).
        cov: Predicted covariances, (n, D, D), symmetric positive definite.
        target: True positions or measurements, (n, D).

    Raises:
        ValueError: on a shape mismatch.
        numpy.linalg.LinAlgError: on a singular covariance.
    """
    mu = np.asarray(mean, dtype=np.float64)
    sigma = np.asarray(cov, dtype=np.float64)
    y = np.asarray(target, dtype=np.float64)
    if mu.ndim != 2 or y.shape != mu.shape or sigma.shape != (*mu.shape, mu.shape[1]):
        raise ValueError(
            f"expected mean (n, D), cov (n, D, D), target (n, D); got {mu.shape}, {sigma.shape}, {y.shape}"
        )
    diff = y - mu
    return np.einsum("nd,nd->n", diff, np.linalg.solve(sigma, diff[..., None])[..., 0])


def _level_key(p: float) -> str:
    return "reliability@" + np.format_float_positional(p, min_digits=2)


class PredictionError:
    """Streaming mean absolute prediction error per track (and pooled / RMS variants).

    ``update(mean, target, track_ids)`` adds predictions (n, D), the measurements the tracks were
    then updated with (n, D) and the track ids (n,), unique and non-negative within one update
    as in a report ([`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]).
    Rows with a non-finite target (coasting tracks) are skipped. Per-track sums (error, squared error, count)
    are merged by track id with `numpy.unique` when read, so memory grows with the number of tracks.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything added."""
        self._ids: list[NDArray[np.int64]] = []
        self._sums: list[NDArray[np.float64]] = []  # rows: (error, error², count)

    def update(self, mean: ArrayLike, target: ArrayLike, track_ids: ArrayLike) -> None:
        """Add predictions ``mean`` (n, D), measurements ``target`` (n, D) and ``track_ids`` (n,)."""
        mu = np.asarray(mean, dtype=np.float64)
        y = np.asarray(target, dtype=np.float64)
        ids = np.asarray(track_ids, dtype=np.int64).reshape(-1)
        if mu.ndim != 2 or y.shape != mu.shape or ids.shape != (len(mu),):
            raise ValueError(
                f"expected mean (n, D), target (n, D), track_ids (n,); got {mu.shape}, {y.shape}, {ids.shape}"
            )
        ok = np.isfinite(y).all(axis=1)
        err = np.linalg.norm(y[ok] - mu[ok], axis=1)
        self._ids.append(ids[ok])
        self._sums.append(np.stack([err, err**2, np.ones_like(err)], axis=1))

    def _per_track(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        ids = np.concatenate([np.zeros(0, np.int64), *self._ids])
        sums = np.concatenate([np.zeros((0, 3)), *self._sums])
        tracks, inverse = np.unique(ids, return_inverse=True)
        merged = np.zeros((len(tracks), 3))
        np.add.at(merged, inverse.reshape(-1), sums)
        self._ids, self._sums = [tracks], [merged]
        return tracks, merged

    def compute(self) -> dict[str, float]:
        """``prediction_error`` (mean over tracks of each track's mean error),
        ``prediction_error_pooled`` (mean over predictions), ``prediction_rmse``, ``n_tracks``,
        ``n_predictions``; the errors are NaN when nothing was added."""
        tracks, sums = self._per_track()
        n = sums[:, 2].sum()
        if n == 0:
            nan = float("nan")
            return {
                "prediction_error": nan,
                "prediction_error_pooled": nan,
                "prediction_rmse": nan,
                "n_tracks": 0.0,
                "n_predictions": 0.0,
            }
        return {
            "prediction_error": float(np.mean(sums[:, 0] / sums[:, 2])),
            "prediction_error_pooled": float(sums[:, 0].sum() / n),
            "prediction_rmse": float(np.sqrt(sums[:, 1].sum() / n)),
            "n_tracks": float(len(tracks)),
            "n_predictions": float(n),
        }


class Nees:
    """Streaming NEES of predicted Gaussians: ``mean(d²) / D`` (≈ 1 when calibrated).

    ``update(mean, cov, target)`` with mean (n, D), cov (n, D, D), target (n, D); rows with a
    non-finite target are skipped. ``D`` must stay the same across updates. Track ids play no
    part (the rows are a tracker's tracks, one per id, as in a report).
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything added."""
        self._sum = 0.0
        self._n = 0
        self._dim: int | None = None

    def _d2(self, mean: ArrayLike, cov: ArrayLike, target: ArrayLike) -> NDArray[np.float64]:
        mu = np.asarray(mean, dtype=np.float64)
        sigma = np.asarray(cov, dtype=np.float64)
        y = np.asarray(target, dtype=np.float64)
        if y.ndim == 2 and y.shape == mu.shape and len(sigma) == len(y):
            ok = np.isfinite(y).all(axis=1)
            mu, sigma, y = mu[ok], sigma[ok], y[ok]
        d2 = mahalanobis_sq(mu, sigma, y)
        dim = mu.shape[1]
        if self._dim is not None and dim != self._dim:
            raise ValueError(f"dimension changed from {self._dim} to {dim} between updates")
        self._dim = dim
        return d2

    def update(self, mean: ArrayLike, cov: ArrayLike, target: ArrayLike) -> None:
        """Add predicted Gaussians N(mean (n, D), cov (n, D, D)) and what happened, target (n, D)."""
        self._add(self._d2(mean, cov, target))

    def _add(self, d2: NDArray[np.float64]) -> None:
        self._sum += float(d2.sum())
        self._n += len(d2)

    def compute(self) -> dict[str, float]:
        """``nees`` (mean d² / D), ``mahalanobis_sq`` (mean d²), ``n``; NaN when empty."""
        if self._n == 0 or self._dim is None:
            return {"nees": float("nan"), "mahalanobis_sq": float("nan"), "n": 0.0}
        mean_d2 = self._sum / self._n
        return {"nees": mean_d2 / self._dim, "mahalanobis_sq": mean_d2, "n": float(self._n)}


class Reliability(Nees):
    """Streaming reliability (calibration) curve of predicted Gaussians, χ² with ``D`` dof.

    Keeps, per expected level ``p``, the count of ``d² ≤ chi2.ppf(p, D)`` (so memory is the size
    of the grid), plus the NEES sums it inherits.

    Args:
        levels: Expected confidence levels in (0, 1); default 0.05, 0.10, ..., 0.95 and 0.999.
    """

    def __init__(self, levels: ArrayLike | None = None) -> None:
        grid = DEFAULT_LEVELS if levels is None else np.asarray(levels, dtype=np.float64).reshape(-1)
        if len(grid) == 0 or not np.all((grid > 0) & (grid < 1)):
            raise ValueError(f"reliability levels must be a non-empty list in (0, 1), got {levels!r}")
        self.levels = np.sort(grid)
        super().__init__()

    def reset(self) -> None:
        """Forget everything added."""
        super().reset()
        self._inside = np.zeros(len(self.levels), dtype=np.int64)

    def _add(self, d2: NDArray[np.float64]) -> None:
        super()._add(d2)
        bounds = chi2.ppf(self.levels, self._dim)
        self._inside += np.count_nonzero(d2[:, None] <= bounds[None, :], axis=0)

    def curve(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Expected levels (k,) and the empirical fraction inside each χ² region (k,)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.levels.copy(), self._inside / np.float64(self._n)

    def compute(self) -> dict[str, float]:
        """``reliability@<p>`` per level, ``calibration_error`` (mean |empirical − expected|),
        ``nees``, ``mahalanobis_sq``, ``n``."""
        expected, empirical = self.curve()
        out = {_level_key(p): float(e) for p, e in zip(expected, empirical, strict=True)}
        out["calibration_error"] = float(np.mean(np.abs(empirical - expected)))
        return out | super().compute()
