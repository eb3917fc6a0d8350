"""The hand-made particle displacement models: Brownian motion and constant velocity on the estimates.

Both declare ``COMMON_DISPLACEMENT``
([`CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel]): every particle of a
target moves by one common displacement ``d_t`` (zero for Brownian motion, the last estimated displacement for
constant velocity) plus white noise ``σ_p·Δ·ε``, ``ε ~ N(0, I_2)``, with ``σ_p`` in multiples of the
step length ``Δ`` (Jung, Schlangen, Charlish, FUSION 2019, Sec. II). The learned model of the same
paper is
[`predictors.displacement_lstm.model.LSTMDisplacement`][predictors.displacement_lstm.model.LSTMDisplacement].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from predictors.displacement.base import DisplacementCapability

#: Step length ``Δ`` of Jung et al. (2019); σ_p and σ_m are given in multiples of it.
STEP = 0.2


def check_sigma(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a float array, checked finite and >= 0 (``ValueError`` naming ``name`` otherwise)."""
    arr = np.asarray(value, dtype=np.float64)
    if not (np.isfinite(arr).all() and np.all(arr >= 0)):
        raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
    return arr


class Brownian:
    """Brownian motion: ``x⁽ⁱ⁾ + σ_p·Δ·ε``, ``ε ~ N(0, I_2)`` (the standard PF of Jung et al. 2019).

    Args:
        sigma_p: Process noise in multiples of ``step``, scalar or one per target (T,).
        step: ``Δ`` in trajectory units (default 0.2).
    """

    #: One common displacement per target plus white noise: the filter's compiled path.
    capabilities = frozenset({DisplacementCapability.COMMON_DISPLACEMENT})

    def __init__(self, sigma_p: ArrayLike = 1.0, step: float = STEP):
        self.sigma_p = check_sigma("sigma_p", sigma_p)
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"step must be a finite number > 0, got {step!r}")
        self.std = self.sigma_p * float(step)

    def _noise(self, shape: tuple[int, ...], rng: np.random.Generator) -> NDArray[np.float64]:
        noise = rng.standard_normal(shape)
        std = self.std if self.std.ndim == 0 else self.std[:, None, None]
        noise *= std
        return noise

    def displacement(self, history: NDArray[np.float64]) -> NDArray[np.float64]:
        """Zeros (T, 2): Brownian motion has no drift."""
        return np.zeros((history.shape[0], 2))

    def propose(
        self, particles: NDArray[np.float64], history: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """``particles + σ_p·Δ·ε`` (the history is not used)."""
        noise = self._noise(particles.shape, rng)
        noise += particles
        return noise


class ConstantVelocityDisplacement(Brownian):
    """Constant velocity on the estimates: ``x⁽ⁱ⁾ + (x*_{t−1} − x*_{t−2}) + σ_p·Δ·ε``.

    Like the LSTM model of Jung et al. (2019) it applies one common displacement to every particle; the
    displacement is zero until a target has two estimates.
    """

    def displacement(self, history: NDArray[np.float64]) -> NDArray[np.float64]:
        """``v = x*_{t−1} − x*_{t−2}`` (T, 2), zero where a target has fewer than two estimates."""
        if history.shape[1] < 2:
            return np.zeros((history.shape[0], 2))
        v = history[:, -1] - history[:, -2]
        v[~np.isfinite(v)] = 0.0
        return v

    def propose(
        self, particles: NDArray[np.float64], history: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """``particles + v + σ_p·Δ·ε`` with ``v`` the last estimated displacement (T, 2)."""
        noise = self._noise(particles.shape, rng)
        noise += particles
        noise += self.displacement(history)[:, None, :]
        return noise
