"""The LSTM displacement model of the LSTM particle filter (Jung et al. 2019, Sec. II-B, Fig. 2).

Jung, Schlangen and Charlish, "Sequential Monte Carlo Filtering with Long Short-Term Memory
Prediction" (FUSION 2019): a displacement LSTM
([`predictors.displacement_lstm.inference`][predictors.displacement_lstm.inference]) runs on the trajectory of
the filter's own weighted-mean estimates ``x*_{0:t−1}``; each frame it reads the ``(r_{t−1}, s_{t−1})`` of the
last two estimates
([`predictors.displacement.geometry.observe_step`][predictors.displacement.geometry.observe_step]) and
predicts ``(r̂_t, ŝ_t)``, which turns the heading ``c`` of the last estimated (non-zero) displacement and is
applied equally to every particle of the target, plus white noise:

    d_t = ŝ_t (cos(c + r̂_t), sin(c + r̂_t)),    x⁽ⁱ⁾ ← x⁽ⁱ⁾ + d_t + σ_p Δ ε⁽ⁱ⁾.

The hidden state ``(h, c)`` (T, 25) is carried per target, so a frame costs one LSTM step per
target whatever the particle count ``N`` (the paper's O(N + H)). A target's state is reset when
its history says its filter (re)started (the newest estimate is its only finite one); until it has
a heading (two distinct estimates) its displacement is zero. The step's products run with BLAS on
one thread ([`track_envs.infra.blas_threads.frame_blas`][track_envs.infra.blas_threads.frame_blas]).
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import ArrayLike, NDArray

from predictors.displacement.base import DisplacementCapability
from predictors.displacement.geometry import apply_displacement, observe_step
from predictors.displacement.models import STEP, check_sigma
from predictors.displacement_lstm.inference import DisplacementLSTM
from predictors.training.model_file import ModelFile
from track_envs.infra.blas_threads import frame_blas

FloatArray = NDArray[np.float64]
#: Implementations of one frame (equal to float rounding).
BACKENDS = ("numba", "numpy")


class LSTMDisplacement:
    """The learned common-displacement model ``"lstm"`` of the particle filter (module docstring), a
    [`CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel].

    Args:
        weights: A ``displacement-lstm`` model file (path with or without suffix, or a loaded
            [`ModelFile`][predictors.training.ModelFile]); ``None`` takes the shipped weights trained
            on the noiseless sine (``predictors/weights/displacement-lstm-sine``).
        sigma_p: White-noise std in multiples of ``step``, scalar or one per target (T,).
        step: ``Δ`` in trajectory units (default 0.2).
        speed_scale: The network's speed scale ``s̄`` in the filter's units; default the model
            file's, rescaled by ``step / Δ_model`` where the file records the step ``Δ_model`` of
            its training data (so the sine model follows a sine drawn with another ``Δ`` or unit).
        backend: ``"numba"`` (one compiled pass over the targets,
            [`predictors.displacement_lstm.inference.DisplacementLSTM.frame`][predictors.displacement_lstm.inference.DisplacementLSTM.frame])
            or ``"numpy"`` (the composition of
            [`predictors.displacement.geometry`][predictors.displacement.geometry] and
            [`predictors.displacement_lstm.inference`][predictors.displacement_lstm.inference] it is tested
            equal to).

    Raises:
        ModelFileError: a missing or corrupt model file, or one of another kind.
        ValueError: a bad ``sigma_p``, ``step``, ``speed_scale`` or ``backend`` (naming the value).
    """

    capabilities = frozenset({DisplacementCapability.COMMON_DISPLACEMENT})  # the compiled path

    def __init__(
        self,
        weights: str | os.PathLike[str] | ModelFile | None = None,
        sigma_p: ArrayLike = 1.0,
        step: float = STEP,
        *,
        speed_scale: float | None = None,
        backend: str = "numba",
    ):
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
        self.backend = backend
        self.sigma_p = check_sigma("sigma_p", sigma_p)
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"step must be a finite number > 0, got {step!r}")
        self.net = DisplacementLSTM.load(weights)
        if speed_scale is None:
            f = self.net.features
            speed_scale = f.speed_scale * (step / f.step if f.step else 1.0)
        elif not (np.isfinite(speed_scale) and speed_scale > 0):
            raise ValueError(f"speed_scale must be a finite number > 0, got {speed_scale!r}")
        self.speed_scale = float(speed_scale)
        #: σ_p·Δ, the white-noise std per target (scalar or (T,)).
        self.std = self.sigma_p * float(step)
        self._reset_state(0)

    def _reset_state(self, n: int) -> None:
        self._h, self._c = self.net.zero_state(n)
        self._heading = np.zeros(n)
        self._has_heading = np.zeros(n, dtype=bool)
        self._length = 0

    def displacement(self, history: NDArray[np.float64]) -> NDArray[np.float64]:
        """The common displacement (T, 2) of each target's particles this frame (zeros where unknown).

        Args:
            history: Weighted-mean estimates (T, t, 2), oldest first, NaN before a target's filter
                (re)started; called once per frame, before the update.

        Raises:
            ValueError: for a history that is not (T, t, 2), holds ±inf, or an estimate with one
                coordinate NaN (naming the target and frame).
        """
        history = np.asarray(history, dtype=np.float64)
        if history.ndim != 3 or history.shape[2] != 2:
            raise ValueError(f"history must have shape (T, t, 2), got {history.shape}")
        n, t = history.shape[0], history.shape[1]
        x = self._check_history(history[:, -2:], t)  # older estimates were read on earlier frames
        if n != len(self._h) or t < self._length:  # another filter, or a new episode
            self._reset_state(n)
        self._length = t
        if t == 0:
            return np.zeros((n, 2))
        newest = x[:, -1]
        previous = x[:, -2] if t >= 2 else np.full((n, 2), np.nan)
        with frame_blas():  # the LSTM step's products (numba's np.dot is scipy's BLAS) on one thread
            if self.backend == "numba":
                state = (self._h, self._c, self._heading, self._has_heading)
                return self.net.frame(newest, previous, state, speed_scale=self.speed_scale)
            return self._displacement_numpy(newest, previous)

    def _displacement_numpy(self, newest: FloatArray, previous: FloatArray) -> FloatArray:
        n = len(newest)
        live = np.isfinite(newest[:, 0])
        restart = ~live | ~np.isfinite(previous[:, 0])
        if restart.any():
            self._h[restart], self._c[restart] = 0.0, 0.0
            self._heading[restart], self._has_heading[restart] = 0.0, False
        step = np.zeros((n, 2))
        np.subtract(newest, previous, out=step, where=~restart[:, None])
        r, s, self._heading, self._has_heading = observe_step(step, self._heading, self._has_heading)
        r_hat, s_hat, self._h, self._c = self.net.step(r, s, self._h, self._c, speed_scale=self.speed_scale)
        _, d = apply_displacement(self._heading, np.zeros((n, 2)), r_hat, s_hat)
        d[~(live & self._has_heading)] = 0.0
        return d

    def propose(
        self, particles: NDArray[np.float64], history: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """``particles + displacement(history)[:, None, :] + σ_p·Δ·ε``, ``ε ~ N(0, I)`` from ``rng``."""
        noise = rng.standard_normal(particles.shape)
        noise *= self.std if self.std.ndim == 0 else self.std[:, None, None]
        noise += particles
        # (T, N·2) += (T, 2) tiled N times: one long inner loop (a (T, 1, 2) broadcast runs N loops of 2)
        noise.reshape(len(noise), -1)[:] += np.tile(self.displacement(history), noise.shape[1])
        return noise

    @staticmethod
    def _check_history(x: FloatArray, t: int) -> FloatArray:
        """``x``: the last (up to) two frames of a history of ``t`` frames."""
        first = t - x.shape[1]
        if np.isinf(x).any():
            target, frame = (int(i) for i in np.argwhere(np.isinf(x))[0][:2])
            where = (target, first + frame)
            raise ValueError(f"history must not hold ±inf; history[{where}] is {x[target, frame].tolist()}")
        half = np.isnan(x[..., 0]) != np.isnan(x[..., 1])
        if half.any():
            target, frame = (int(i) for i in np.argwhere(half)[0])
            raise ValueError(
                f"history[{(target, first + frame)}] is {x[target, frame].tolist()}: an estimate is "
                "either finite or all NaN (before a target's filter started)"
            )
        return x
