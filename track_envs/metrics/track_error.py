"""The distribution of the per-track mean absolute prediction error (box-plot statistics).

Pollithy, Reith-Braun, Pfaff, Hanebeck, "Estimating Uncertainties of Recurrent Neural Networks in
Application to Multitarget Tracking" (2020), Fig. 6, show box plots of one value per track: for
track ``k`` with one-step predictions ``ŷ_{k,t}`` of the measurements ``y_{k,t}`` it was then
updated with,

    MAE_k = (1 / n_k) Σ_t ||ŷ_{k,t} − y_{k,t}||₂ .

[`TrackErrorDistribution`][track_envs.metrics.TrackErrorDistribution] streams the per-track sums of
[`PredictionError`][track_envs.metrics.PredictionError] and summarises the ``MAE_k`` by the
quantiles of a box plot (5, 25, 50, 75 and 95 %, linear interpolation between order statistics,
``numpy.quantile``'s default) plus their mean and count, so a record of flat floats carries the
whole box.
"""

from __future__ import annotations

import numpy as np

from track_envs.metrics.prediction import PredictionError

#: The quantiles reported (box: 25–75 %, median, whiskers 5 % and 95 %).
BOX_QUANTILES = (0.05, 0.25, 0.50, 0.75, 0.95)


def quantile_key(q: float) -> str:
    """``track_error_p05`` … ``track_error_p95``: the key of quantile ``q`` of the per-track errors."""
    return f"track_error_p{round(100 * q):02d}"


class TrackErrorDistribution(PredictionError):
    """Streaming distribution over tracks of each track's mean absolute prediction error.

    Fed like [`PredictionError`][track_envs.metrics.PredictionError] (``update(mean, target,
    track_ids)``; rows with a non-finite target are skipped; memory grows with the number of
    tracks). Every track with at least one scored prediction counts once.

    Args:
        min_predictions: Tracks with fewer scored predictions are left out (default 1: all).
    """

    def __init__(self, min_predictions: int = 1) -> None:
        if not (isinstance(min_predictions, int) and min_predictions >= 1):
            raise ValueError(f"min_predictions must be an integer >= 1, got {min_predictions!r}")
        self.min_predictions = min_predictions
        super().__init__()

    def per_track(self) -> np.ndarray:
        """``MAE_k`` of every counted track, in track-id order."""
        _, sums = self._per_track()
        keep = sums[:, 2] >= self.min_predictions
        return np.asarray(sums[keep, 0] / sums[keep, 2], dtype=np.float64)

    def compute(self) -> dict[str, float]:
        """The [`PredictionError`][track_envs.metrics.PredictionError] keys plus ``track_error_p05`` …
        ``track_error_p95``, ``track_error_mean`` and ``track_error_tracks`` (the errors NaN when no track
        counts)."""
        out = super().compute()
        values = self.per_track()
        if len(values) == 0:
            out |= {quantile_key(q): float("nan") for q in BOX_QUANTILES}
            out["track_error_mean"] = float("nan")
        else:
            qs = np.quantile(values, BOX_QUANTILES)
            out |= {quantile_key(q): float(v) for q, v in zip(BOX_QUANTILES, qs, strict=True)}
            out["track_error_mean"] = float(values.mean())
        out["track_error_tracks"] = float(len(values))
        return out
