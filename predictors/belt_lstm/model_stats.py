"""What a trained belt network needs besides its weights: covariance scale, τ, calibration, test metrics.

* ``mc``: the Monte Carlo precision ``τ = p l² / (2 N λ)`` of Pollithy et al. (2020, Sec. II-B),
  with ``p`` the keep probability, ``l = 1e-2`` the prior length scale, ``N`` the number of training
  predictions and ``λ = 1e-5`` the L2 weight; stored in standardised output units.
* ``calibration.cov_scale`` (``lstm``): the mean squared one-step error per axis on the validation
  tracks (sensor units²), the covariance ``s·I`` of a model that predicts none.
* ``calibration.scale``: the factor ``r`` of
[`predictors.training.calibration`][predictors.training.calibration], fitted on the
  validation tracks at ``p_des = 0.999``.
* ``metrics``: on the test tracks, the mean per-track one-step error (sensor units), the NEES and
  the empirical coverage at 0.999 before and after calibration.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from predictors.belt_lstm.network import BeltLSTMNet, Features
from predictors.belt_lstm.training import NoiseStd, check_noise_std, noisy_tracks, to_model_file
from predictors.training.calibration import P_DES, coverage, fit_recalibration
from predictors.training.data import TrackSet, TrackSplit
from predictors.training.evaluate import OneStepResult, one_step_predictions
from predictors.training.model_file import ModelFile
from track_envs.values.types import SensorSpec

#: Prior length scale ``l`` of the MC-dropout precision (Pollithy et al. 2020, Sec. IV-C).
LENGTH_SCALE = 1e-2
#: L2 weight ``λ`` (Sec. IV-A).
L2 = 1e-5


def spec_of(data: TrackSet, noise_std: NoiseStd) -> SensorSpec:
    """A sensor spec with the geometry of ``data`` and the (largest) measurement noise ``noise_std``."""
    return SensorSpec(
        dt=data.dt,
        dim=data.dim,
        noise_std=max(check_noise_std(noise_std)[1], 1e-6),
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=data.region_low,
        region_high=data.region_high,
        max_detections=1,
        max_tracks=1,
    )


def mc_precision(dropout: float, train_steps: int) -> float | None:
    """``τ = p l² / (2 N λ)`` with keep probability ``p = 1 − dropout`` (``None`` without dropout)."""
    if dropout == 0.0:
        return None
    return (1.0 - dropout) * LENGTH_SCALE**2 / (2.0 * train_steps * L2)


def predictions_of(model: ModelFile, data: TrackSet, noise_std: NoiseStd, seed: int) -> OneStepResult:
    """One-step predictions of a belt model on ``data`` (noise and mc masks seeded by ``seed``)."""
    from predictors.belt_lstm.predictor import LSTMPredictor

    predictor = LSTMPredictor(model.kind, model)
    predictor.reset(spec_of(data, noise_std), rng=np.random.default_rng(seed))
    return one_step_predictions(predictor, noisy_tracks(data, noise_std, seed).tracks)


def _run(
    net: BeltLSTMNet, features: Features, meta: dict[str, Any], data: TrackSet, noise_std: NoiseStd, seed: int
) -> OneStepResult:
    return predictions_of(to_model_file(net, features, **meta), data, noise_std, seed)


def model_statistics(
    net: BeltLSTMNet, features: Features, split: TrackSplit, *, noise_std: NoiseStd, seed: int
) -> dict[str, Any]:
    """``{"mc": ..., "calibration": ..., "metrics": ...}`` for the sidecar of a trained network."""
    steps = int(sum(len(t) - 1 for t in split.train.tracks))
    tau = mc_precision(net.dropout, steps)
    mc = {"tau": tau, "length_scale": LENGTH_SCALE, "l2": L2, "train_predictions": steps}
    validation = split.validation if len(split.validation) else split.train
    meta: dict[str, Any] = {"mc": mc, "calibration": {"scale": 1.0, "cov_scale": 1.0}}
    if net.kind == "lstm":
        first = _run(net, features, meta, validation, noise_std, seed + 2)
        _, _, targets = first.flat()
        means = first.flat()[0]
        meta["calibration"]["cov_scale"] = float(np.mean((targets - means) ** 2))
    before = _run(net, features, meta, validation, noise_std, seed + 2)
    cal = fit_recalibration(*before.flat(), p_des=P_DES)
    meta["calibration"]["scale"] = cal.scale
    meta["calibration"]["p_des"] = P_DES
    meta["calibration"]["validation_coverage_before"] = coverage(before.valid_d2(), P_DES, net.dim)
    test = split.test if len(split.test) else validation
    test_result = _run(net, features, meta, test, noise_std, seed + 3)
    d2_after = test_result.valid_d2()
    metrics = {
        "test_mean_error": float(np.mean(test_result.per_track_mean_error())),
        "test_nees": float(np.mean(d2_after) / net.dim),
        "test_coverage_999_uncalibrated": coverage(d2_after * cal.scale, P_DES, net.dim),
        "test_coverage_999": coverage(d2_after, P_DES, net.dim),
        "test_predictions": len(d2_after),
    }
    return {"mc": mc, "calibration": meta["calibration"], "metrics": metrics}


def predictive_log_likelihood(result: OneStepResult) -> float:
    """Mean Gaussian log-likelihood ``log N(y; ŷ, Σ)`` of the valid one-step predictions.

    The score of the dropout-rate grid search (Pollithy et al. 2020, Sec. IV-C, after Gal and
    Ghahramani): for MC dropout, ``ŷ`` and ``Σ`` are the sample mean and eq. (4)'s covariance.
    """
    means, covs, targets = result.flat()
    diff = targets - means
    d2 = np.einsum("nd,nd->n", diff, np.linalg.solve(covs, diff[..., None])[..., 0])
    _, logdet = np.linalg.slogdet(2.0 * np.pi * covs)
    return float(np.mean(-0.5 * (d2 + logdet)))


def dropout_grid(
    split: TrackSplit,
    rates: list[float],
    config: Any,
    *,
    noise_std: NoiseStd,
    seed: int,
    samples: int = 100,
    progress: bool = False,
) -> list[dict[str, float]]:
    """Train mc-lstm once per dropout rate (short runs) and score each on the validation tracks.

    Returns one ``{"dropout", "validation_log_likelihood", "validation_mean_error"}`` per rate.
    """
    from predictors.belt_lstm.predictor import LSTMPredictor
    from predictors.belt_lstm.training import train_belt_model

    rows = []
    steps = int(sum(len(t) - 1 for t in split.train.tracks))
    for rate in rates:
        net, features, _ = train_belt_model(
            "mc-lstm", split, config, dropout=rate, noise_std=noise_std, progress=progress
        )
        model = to_model_file(net, features, mc={"tau": mc_precision(rate, steps)})
        predictor = LSTMPredictor("mc-lstm", model, samples=samples)
        predictor.reset(spec_of(split.validation, noise_std), rng=np.random.default_rng(seed))
        result = one_step_predictions(predictor, noisy_tracks(split.validation, noise_std, seed + 1).tracks)
        rows.append(
            {
                "dropout": rate,
                "validation_log_likelihood": predictive_log_likelihood(result),
                "validation_mean_error": float(np.mean(result.per_track_mean_error())),
            }
        )
    return rows
