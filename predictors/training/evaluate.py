"""One-step prediction with true associations: per-track errors and Mahalanobis distances.

Any Predictor is run over whole tracks at once (batched over tracks): all tracks start at their
first measurement, then every frame each track is predicted and updated with its own next
measurement, so association plays no part. For step ``t`` of track ``i`` this records the error
``‖ŷ_{i,t} − z_{i,t}‖`` and the squared Mahalanobis distance
``d² = (z − ŷ)ᵀ S⁻¹ (z − ŷ)``, from which

* the *per-track mean prediction error* (Pollithy et al. 2020, Fig. 6: the mean over a track's
  predictions, one value per track), and
* the reliability curve and calibration of
[`predictors.training.calibration`][predictors.training.calibration]

are computed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.training.data import pad_tracks

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class OneStepResult:
    """Per-step results over a padded batch of tracks.

    Attributes:
        errors: ``(B, T − 1)`` Euclidean errors of the predictions of steps 1..T−1 (NaN past a track's end).
        d2: ``(B, T − 1)`` squared Mahalanobis distances of the same predictions.
        means: ``(B, T − 1, D)`` the predicted means.
        covariances: ``(B, T − 1, D, D)`` the predicted covariances.
        targets: ``(B, T − 1, D)`` the measurements that followed (NaN past a track's end).
    """

    errors: FloatArray
    d2: FloatArray
    means: FloatArray
    covariances: FloatArray
    targets: FloatArray

    def per_track_mean_error(self) -> FloatArray:
        """Mean error of each track over its predictions (tracks with none are dropped)."""
        valid = np.isfinite(self.errors)
        keep = valid.any(axis=1)
        return np.nanmean(self.errors[keep], axis=1)

    def valid_d2(self) -> FloatArray:
        """All finite squared Mahalanobis distances, flat."""
        return self.d2[np.isfinite(self.d2)]

    def flat(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(means (N, D), covariances (N, D, D), targets (N, D))`` of every valid prediction."""
        ok = np.isfinite(self.d2)
        return self.means[ok], self.covariances[ok], self.targets[ok]


def one_step_predictions(predictor: Any, tracks: Sequence[NDArray[np.floating]]) -> OneStepResult:
    """Run ``predictor`` (already ``reset`` to a spec) over ``tracks`` with true associations."""
    z, valid = pad_tracks(tracks)
    B, T, D = z.shape
    errors = np.full((B, T - 1), np.nan)
    d2 = np.full((B, T - 1), np.nan)
    covs = np.full((B, T - 1, D, D), np.nan)
    means = np.full((B, T - 1, D), np.nan)
    targets = np.full((B, T - 1, D), np.nan)
    state = predictor.start(z[:, 0])
    for t in range(1, T):
        state, prediction = predictor.predict(state)
        seen = valid[:, t]
        diff = z[:, t] - prediction.mean
        e = np.linalg.norm(diff, axis=1)
        m = np.einsum("nd,nd->n", diff, np.linalg.solve(prediction.cov, diff[..., None])[..., 0])
        errors[seen, t - 1] = e[seen]
        d2[seen, t - 1] = m[seen]
        covs[seen, t - 1] = prediction.cov[seen]
        means[seen, t - 1] = prediction.mean[seen]
        targets[seen, t - 1] = z[seen, t]
        z_in = np.where(seen[:, None], z[:, t], prediction.mean)
        state = predictor.update(state, z_in, seen)
    return OneStepResult(errors, d2, means, covs, targets)
