"""The belt LSTMs' features: region-relative, standardised measurement sequences.

Separate from [`predictors.belt_lstm.network`][predictors.belt_lstm.network] so that inference with a shipped
model needs no torch; the network module re-exports [`Features`][predictors.belt_lstm.features.Features]. The
per-frame inputs of a batch of tracks ([`Features.inputs`][predictors.belt_lstm.features.Features.inputs]) and
nll-lstm's predicted Gaussian ([`nll_gaussian`][predictors.belt_lstm.features.nll_gaussian]) are compiled
passes with the same floating-point operations as the numpy expressions they replace (the same bits; tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit


@njit(cache=True)
def standardised_inputs(
    z: np.ndarray,
    z_prev: np.ndarray,
    has_prev: bool,
    low: np.ndarray,
    size: np.ndarray,
    in_mean: np.ndarray,
    in_std: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out = ((u, Δu) − μ_in) / σ_in`` (n, 2D) with ``u = (z − low) / size`` and
    ``Δu = u − (z_prev − low) / size`` (``Δu = 0`` without ``has_prev``), element by element in
    float64 (the operations of the numpy form in
    [`Features.inputs`][predictors.belt_lstm.features.Features.inputs])."""
    n, d = z.shape
    for r in range(n):
        for j in range(d):
            u = (z[r, j] - low[j]) / size[j]
            du = u - (z_prev[r, j] - low[j]) / size[j] if has_prev else 0.0
            out[r, j] = (u - in_mean[j]) / in_std[j]
            out[r, d + j] = (du - in_mean[d + j]) / in_std[d + j]


@njit(cache=True)
def nll_gaussian(
    z_prev: np.ndarray,
    out: np.ndarray,
    var_std: np.ndarray,
    size: np.ndarray,
    out_mean: np.ndarray,
    out_std: np.ndarray,
    scale: np.ndarray,
    calibration: float,
    mean: np.ndarray,
    cov: np.ndarray,
) -> None:
    """The nll-lstm prediction in one pass: ``mean = z_prev + size ⊙ (μ_out + σ_out ⊙ out)`` (n, D)
    ([`Features.position`][predictors.belt_lstm.features.Features.position]) and
    ``cov = r · diag(var_std ⊙ scale)`` (n, D, D) with ``var_std = exp(log σ²)`` (computed by numpy's ``exp``)
    and ``r = calibration``, element by element in float64 (the operations of the numpy form)."""
    n, d = z_prev.shape
    for r in range(n):
        for j in range(d):
            mean[r, j] = z_prev[r, j] + size[j] * (out_mean[j] + out_std[j] * out[r, j])
            for k in range(d):
                cov[r, j, k] = calibration * 0.0
            cov[r, j, j] = calibration * (var_std[r, j] * scale[j])


@dataclass(frozen=True)
class Features:
    """Region-relative, standardised features of a measurement sequence.

    Attributes:
        low, size: The sensor region's lower corner and size (D,), in sensor units.
        in_mean, in_std: Mean and std of the input features ``(u, Δu)`` (2D,).
        out_mean, out_std: Mean and std of the target displacement ``Δu`` (D,).
    """

    low: NDArray[np.float64]
    size: NDArray[np.float64]
    in_mean: NDArray[np.float64]
    in_std: NDArray[np.float64]
    out_mean: NDArray[np.float64]
    out_std: NDArray[np.float64]

    @classmethod
    def fit(cls, tracks: list[NDArray[np.float64]], low: Any, high: Any, floor: float = 1e-9) -> Features:
        """Normalisation statistics of ``tracks`` (each ``(T, D)``) in the region ``[low, high]``."""
        low_a = np.asarray(low, dtype=np.float64)
        size = np.asarray(high, dtype=np.float64) - low_a
        u = [(t - low_a) / size for t in tracks]
        du = np.concatenate([np.diff(x, axis=0) for x in u if len(x) > 1])
        inputs = np.concatenate([np.concatenate([x, _diff0(x)], axis=1) for x in u])
        return cls(
            low_a,
            size,
            inputs.mean(axis=0),
            np.maximum(inputs.std(axis=0), floor),
            du.mean(axis=0),
            np.maximum(du.std(axis=0), floor),
        )

    def to_dict(self) -> dict[str, list[float]]:
        """JSON form for a model sidecar."""
        return {k: np.asarray(getattr(self, k)).tolist() for k in self.__dataclass_fields__}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Features:
        """Inverse of [`to_dict`][predictors.belt_lstm.features.Features.to_dict]."""
        return cls(**{k: np.asarray(d[k], dtype=np.float64) for k in cls.__dataclass_fields__})

    def inputs(self, z: NDArray[np.float64], z_prev: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Standardised input ``(u, Δu)`` (n, 2D) of measurements ``z`` (n, D) after ``z_prev``
        (``None``: ``Δu = 0``); float64 (n, D) arrays take the compiled pass."""
        if (
            isinstance(z, np.ndarray)
            and z.ndim == 2
            and z.dtype == np.float64
            and (z_prev is None or (isinstance(z_prev, np.ndarray) and z_prev.dtype == np.float64))
            and (z_prev is None or z_prev.shape == z.shape)
            and z.shape[1] == len(self.low)
        ):
            out = np.empty((len(z), 2 * z.shape[1]))
            has_prev = z_prev is not None
            standardised_inputs(
                z, z_prev if has_prev else z, has_prev,
                self.low, self.size, self.in_mean, self.in_std, out,
            )  # fmt: skip
            return out
        u = (z - self.low) / self.size
        du = np.zeros_like(u) if z_prev is None else u - (z_prev - self.low) / self.size
        return (np.concatenate([u, du], axis=-1) - self.in_mean) / self.in_std

    def sequence_inputs(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """[`inputs`][predictors.belt_lstm.features.Features.inputs] of a padded batch of sequences
        ``(B, T, D)`` → ``(B, T, 2D)``."""
        u = (z - self.low) / self.size
        du = np.concatenate([np.zeros_like(u[:, :1]), np.diff(u, axis=1)], axis=1)
        return (np.concatenate([u, du], axis=-1) - self.in_mean) / self.in_std

    def targets(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """Standardised next displacement ``(B, T − 1, D)`` of sequences ``(B, T, D)``."""
        du = np.diff((z - self.low) / self.size, axis=1)
        return (du - self.out_mean) / self.out_std

    def position(self, z: NDArray[np.float64], out: NDArray[np.float64]) -> NDArray[np.float64]:
        """The predicted next measurement from the last one ``z`` and the standardised output."""
        return z + self.size * (self.out_mean + self.out_std * out)

    def variance_scale(self) -> NDArray[np.float64]:
        """Factor from a standardised output variance to sensor units², per axis (D,)."""
        return (self.size * self.out_std) ** 2


def _diff0(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([np.zeros_like(x[:1]), np.diff(x, axis=0)], axis=0)
