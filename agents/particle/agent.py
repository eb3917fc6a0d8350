"""Bootstrap particle filter of Jung et al. (2019) (Algorithm 1), batched over targets and particles.

State of ``T`` independent single-target filters with ``N`` particles each: particles ``x⁽ⁱ⁾``
(T, N, 2), weights ``w⁽ⁱ⁾`` (T, N), and the history of weighted-mean estimates (T, t, 2). One
frame (Jung, Schlangen, Charlish, FUSION 2019, Sec. II–III):

1. **predict**: a displacement model ([`predictors.displacement`][predictors.displacement]) moves every
particle,
   ``x⁽ⁱ⁾ ← propose(x⁽ⁱ⁾, x*_{0:t−1})``; the Brownian model adds white noise ``σ_p`` (in multiples
   of ``Δ``), the constant-velocity model adds the last estimated displacement plus that noise, and
   the LSTM model of Jung et al. (2019)
   ([`predictors.displacement_lstm.model.LSTMDisplacement`][predictors.displacement_lstm.model.LSTMDisplacement],
   ``model="lstm"``) predicts one common (rotation, speed) step from the estimate history plus that noise —
   all through the [`DisplacementModel`][predictors.displacement.base.DisplacementModel] protocol, so the
   filter never changes;
2. **update** (only when a measurement ``z`` arrives, Eq. (4)):
   ``w⁽ⁱ⁾ ∝ w⁽ⁱ⁾ · exp(−||x⁽ⁱ⁾ − z||² / (2σ_m²))``; without a measurement the filter only predicts;
3. **estimate**: the weighted mean ``x* = Σ_i w⁽ⁱ⁾ x⁽ⁱ⁾``, appended to the history;
4. **resample**: when ``N_eff = 1 / Σ_i (w⁽ⁱ⁾)² < N/2``, systematic (low-variance) resampling
   (Thrun, Burgard, Fox, "Probabilistic Robotics", 2005, Table 4.4) and ``w⁽ⁱ⁾ = 1/N``.

A filter starts at its first measurement ``z₀``: ``x⁽ⁱ⁾ ~ N(z₀, Σ₀)``, ``Σ₀ = σ₀² I``, ``w = 1/N``.
All per-frame work is batched over (T, N); parameters may differ per target ((T,) arrays), which is
how ``examples/pf_paper_figures.py`` runs whole parameter grids and Monte Carlo runs at once.
A model that declares it moves every particle of a target by one common displacement plus white
noise (``COMMON_DISPLACEMENT``,
[`CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel]:
Brownian, constant velocity, the LSTM of Jung et al.) runs the frame in a few compiled single passes
([`agents.particle._kernels`][agents.particle._kernels]); any other
[`DisplacementModel`][predictors.displacement.base.DisplacementModel] runs the numpy path through its
``propose``. Both draw the same random numbers from the filter's generator in the same order, and
agree to rounding.

The agent ``"pf"`` ([`ParticleFilterAgent`][agents.particle.agent.ParticleFilterAgent]) tracks one target with
``T = 1``. Clutter: when the sensor has clutter (``spec.clutter_rate > 0``) or a frame holds more than one
detection, the update uses the detection nearest to the predicted mean in Mahalanobis distance
under ``S = Cov_w(x⁽ⁱ⁾) + σ_m² I`` if it lies inside the χ²₂ gate of probability ``p_gate``,
and no detection otherwise (the frame is then a prediction-only frame). With clutter the filter
also starts only on a detection confirmed by one of the previous frame's detections within
``init_radius``, and it restarts (the same way) after ``max_misses`` frames in a row that had
detections but none in the gate — a filter started on clutter, or one that lost its target, does
not drift forever. Without clutter the first detection starts the filter and it never restarts.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.base import AgentTraits
from agents.particle._kernels import (
    add_common,
    all_finite,
    count_new,
    log_likelihood,
    predict_common,
    resample_rows,
    update_rows,
)
from predictors.displacement import (
    STEP,
    CommonDisplacementModel,
    DisplacementCapability,
    DisplacementModel,
    check_sigma,
    displacement_capability,
    make_displacement_model,
)
from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import empty_report
from track_envs.infra.blas_threads import frame_blas
from track_envs.values.types import SensorSpec

#: Particles (T·N) from which the compiled prediction draws its noise inside the kernel, below
#: which numpy draws it (see ``BatchParticleFilter.predict``).
RNG_IN_KERNEL_PARTICLES = 512


def systematic_resample_batch(weights: NDArray[np.float64], u: ArrayLike) -> NDArray[np.intp]:
    """Systematic (low-variance) resampling of ``T`` weight vectors at once.

    Row ``r`` takes the positions ``p_k = (u_r + k) / N``, ``k = 0 … N−1``, and picks for each the
    first index ``j`` with ``p_k < cumsum(w_r)[j]`` (filterpy's rule; a position beyond the last
    cumulative sum, a rounding effect, picks ``N − 1``). Since both sequences are sorted, index
    ``j`` is picked ``n_j − n_{j−1}`` times with ``n_j = #{k : p_k < cumsum_j}``; ``n_j`` is
    ``⌈N·cumsum_j − u_r⌉`` corrected by one step against the exact comparison, so the result equals
    the sequential algorithm bit for bit, in O(N) per row.

    Args:
        weights: (T, N) normalised weights.
        u: (T,) uniform draws in [0, 1).

    Returns:
        (T, N) *flat* indices into the (T·N) particles, row ``r`` in ``[r·N, (r+1)·N)``, sorted.
    """
    w = np.asarray(weights, dtype=np.float64)
    t, n = w.shape
    uu = np.asarray(u, dtype=np.float64).reshape(t, 1)
    cumsum = np.cumsum(w, axis=1)
    count = np.clip(np.ceil(cumsum * n - uu), 0, n)
    # exact correction: count_j = smallest k with p_k >= cumsum_j (k = n when none)
    below = (count < n) & ((uu + np.minimum(count, n - 1)) / n < cumsum)
    count += below
    above = (count > 0) & ((uu + np.maximum(count - 1, 0)) / n >= cumsum)
    count -= above
    count[:, -1] = n
    picks = np.diff(count, axis=1, prepend=0.0).astype(np.intp).ravel()
    return np.repeat(np.arange(t * n), picks).reshape(t, n)


def systematic_resample(weights: ArrayLike, u: float) -> NDArray[np.intp]:
    """Systematic resampling of one weight vector (N,) with the uniform draw ``u``: the indices (N,).

    Equals ``filterpy.monte_carlo.systematic_resample(weights)`` when its ``random()`` returns ``u``.
    """
    return systematic_resample_batch(np.asarray(weights, dtype=np.float64)[None], [u])[0]


class BatchParticleFilter:
    """``T`` bootstrap particle filters of ``N`` particles stepped together (module docstring).

    ``fused`` says whether the model runs the compiled path (it declares ``COMMON_DISPLACEMENT``);
    that path updates ``particles`` and ``weights`` in place (copy them to keep a frame's cloud).

    Args:
        n_targets: ``T``.
        n_particles: ``N`` >= 1.
        model: The displacement model (prediction step).
        sigma_m: Measurement noise std in trajectory units, scalar or (T,), > 0.
        sigma_0: Std of the initial particle cloud around the first measurement, scalar or (T,).
        rng: The generator every draw comes from.
        resample_threshold: Resample when ``N_eff < resample_threshold · N`` (paper: 1/2).
    """

    def __init__(
        self,
        n_targets: int,
        n_particles: int,
        model: DisplacementModel,
        *,
        sigma_m: ArrayLike,
        sigma_0: ArrayLike,
        rng: np.random.Generator,
        resample_threshold: float = 0.5,
    ):
        for name, value in (("n_targets", n_targets), ("n_particles", n_particles)):
            if not (isinstance(value, int | np.integer) and value >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        sm = check_sigma("sigma_m", sigma_m)
        if np.any(sm <= 0):
            raise ValueError(f"sigma_m must be > 0, got {sigma_m!r}")
        if not 0.0 <= resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must be in [0, 1], got {resample_threshold!r}")
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.T, self.N = int(n_targets), int(n_particles)
        self.model = model
        self.rng = rng
        self.sigma_0 = np.broadcast_to(check_sigma("sigma_0", sigma_0), (self.T,))
        self.sigma_m = np.broadcast_to(sm, (self.T,))
        self._inv_2var = (0.5 / self.sigma_m**2)[:, None]
        # contiguous copies and scratch of the compiled path
        self._inv_2var_flat = np.ascontiguousarray(self._inv_2var[:, 0])
        self._sigma_0 = np.ascontiguousarray(self.sigma_0, dtype=np.float64)
        self._lik = np.empty((self.T, self.N))
        self._new = np.zeros(self.T, dtype=bool)
        self._low = np.zeros(self.T, dtype=bool)
        self._no_cloud = np.zeros((0, self.N, 2))
        self._rng_in_kernel = self.T * self.N >= RNG_IN_KERNEL_PARTICLES
        self._noise = np.empty((0, self.N, 2) if self._rng_in_kernel else (self.T, self.N, 2))
        self.resample_threshold = float(resample_threshold)
        self.particles = np.zeros((self.T, self.N, 2))
        self.weights = np.full((self.T, self.N), 1.0 / self.N)
        self.started = np.zeros(self.T, dtype=bool)
        self._history = np.full((self.T, 16, 2), np.nan)
        self.length = 0
        self.resampled = 0

    @property
    def history(self) -> NDArray[np.float64]:
        """The weighted-mean estimates so far (T, t, 2), NaN before a target's filter started."""
        return self._history[:, : self.length]

    @property
    def estimate(self) -> NDArray[np.float64]:
        """The current weighted-mean estimate (T, 2), NaN where the filter has not started."""
        with frame_blas():  # a per-frame product: one BLAS thread (track_envs.infra.blas_threads)
            mean = np.matmul(self.weights[:, None, :], self.particles)[:, 0]
        mean[~self.started] = np.nan
        return mean

    def moments(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Weighted mean (T, 2) and covariance (T, 2, 2) of the particles."""
        with frame_blas():
            mean = np.matmul(self.weights[:, None, :], self.particles)[:, 0]
            d = self.particles - mean[:, None, :]
            cov = np.matmul((d * self.weights[..., None]).transpose(0, 2, 1), d)
        return mean, cov

    @property
    def model(self) -> DisplacementModel:
        """The displacement model; one that declares ``COMMON_DISPLACEMENT`` runs the compiled path."""
        return self._model

    @model.setter
    def model(self, model: DisplacementModel) -> None:
        self._model = model
        self._common: CommonDisplacementModel | None = displacement_capability(
            model, DisplacementCapability.COMMON_DISPLACEMENT
        )
        self.fused = self._common is not None

    def predict(self) -> None:
        """Move every particle with the displacement model (step 1)."""
        if self.fused:
            # passing a Generator into a compiled function costs ≈10 µs, more than drawing a few
            # hundred numbers with numpy; numba's draws equal numpy's, so either gives the same
            displacement, std = self._common_step()
            if self._rng_in_kernel:
                predict_common(self.particles, displacement, std, self.rng)
            else:
                add_common(self.particles, displacement, std, self.rng.standard_normal(out=self._noise))
        else:
            self.particles = self.model.propose(self.particles, self.history, self.rng)

    def update(self, z: ArrayLike, has_z: ArrayLike) -> NDArray[np.float64]:
        """Weight (Eq. (4)) or start the filters that have a measurement, estimate, resample.

        Args:
            z: Measurements (T, 2) (rows without one are ignored).
            has_z: (T,) bool, whether row ``t`` has a measurement this frame.

        Returns:
            The estimates (T, 2) of this frame, NaN where a filter has not started.
        """
        if self.fused:
            return self._compiled_frame(z, has_z, predict=False)
        z = np.asarray(z, dtype=np.float64).reshape(self.T, 2)
        has = np.asarray(has_z, dtype=bool).reshape(self.T)
        weigh = has & self.started
        if weigh.all():
            self._weigh(slice(None), z)
        elif weigh.any():
            self._weigh(np.flatnonzero(weigh), z[weigh])
        new = has & ~self.started
        if new.any():
            rows = np.flatnonzero(new)
            cloud = self.rng.standard_normal((len(rows), self.N, 2)) * self.sigma_0[rows, None, None]
            self.particles[rows] = cloud + z[rows, None, :]
            self.weights[rows] = 1.0 / self.N
            self.started |= new
            # a (re)started target has no past: the displacement models must not read the lost
            # track's estimates as its history
            self._history[rows, : self.length] = np.nan
        estimate = self.estimate
        self._append(estimate)
        self._resample()
        return estimate

    def step(self, z: ArrayLike, has_z: ArrayLike) -> NDArray[np.float64]:
        """One frame: [`predict`][agents.particle.agent.BatchParticleFilter.predict] then
        [`update`][agents.particle.agent.BatchParticleFilter.update]; returns the estimates (T, 2).

        For a model that declares ``COMMON_DISPLACEMENT`` the frame runs the compiled kernels
        ([`agents.particle._kernels`][agents.particle._kernels])."""
        if self.fused:
            return self._compiled_frame(z, has_z, predict=True)
        self.predict()
        return self.update(z, has_z)

    def _common_step(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The model's displacement (T, 2) and noise std (1,) or (T,), checked."""
        model = self._common
        assert model is not None, "the compiled path needs a COMMON_DISPLACEMENT model"
        displacement = np.ascontiguousarray(model.displacement(self.history), dtype=np.float64)
        if displacement.shape != (self.T, 2) or not all_finite(displacement):
            raise ValueError(
                f"{type(model).__name__}.displacement() must return finite values of shape "
                f"({self.T}, 2), got {displacement.shape}: {displacement[:3].tolist()}"
            )
        std = np.asarray(model.std, dtype=np.float64).reshape(-1)
        if std.shape[0] not in (1, self.T):
            raise ValueError(
                f"{type(model).__name__}.std must be a scalar or have {self.T} entries, got {std.shape}"
            )
        return displacement, std

    def _compiled_frame(self, z: ArrayLike, has_z: ArrayLike, *, predict: bool) -> NDArray[np.float64]:
        """Frame of the compiled path ([`agents.particle._kernels`][agents.particle._kernels]), the same steps
        and draws as predict (optionally) + update of the numpy path; ``exp`` is numpy's (vectorised)."""
        z = np.ascontiguousarray(z, dtype=np.float64).reshape(self.T, 2)
        has = np.ascontiguousarray(has_z, dtype=bool).reshape(self.T)
        if predict:
            self.predict()
        if self.length == self._history.shape[1]:
            self._grow()
        n_new = count_new(self.started, has)
        cloud = self.rng.standard_normal((n_new, self.N, 2)) if n_new else self._no_cloud
        lik = self._lik
        log_likelihood(self.particles, self.started, z, has, self._inv_2var_flat, lik)
        np.exp(lik, out=lik)
        estimate = np.empty((self.T, 2))
        n_low = update_rows(
            self.particles,
            self.weights,
            self.started,
            z,
            has,
            lik,
            cloud,
            self._sigma_0,
            self.resample_threshold,
            estimate,
            self._new,
            self._low,
        )
        if n_low:
            resample_rows(self.particles, self.weights, self._low, self.rng.random(n_low))
            self.resampled += n_low
        if n_new:  # a (re)started target has no past (see update)
            self._history[self._new, : self.length] = np.nan
        self._history[:, self.length] = estimate
        self.length += 1
        return estimate

    def _weigh(self, rows: slice | NDArray[np.intp], z: NDArray[np.float64]) -> None:
        diff = self.particles[rows] - z[:, None, :]
        loglik = np.einsum("tnd,tnd->tn", diff, diff)
        loglik *= -self._inv_2var[rows]
        loglik -= loglik.max(axis=1, keepdims=True)
        lik = np.exp(loglik, out=loglik)
        w = self.weights[rows] * lik
        total = w.sum(axis=1, keepdims=True)
        bad = ~(total[:, 0] > 0) | ~np.isfinite(total[:, 0])
        if bad.any():  # every prior weight underflowed against the likelihood: keep the likelihood
            w[bad] = lik[bad]
            total[bad] = lik[bad].sum(axis=1, keepdims=True)
        w /= total
        self.weights[rows] = w

    def _grow(self) -> None:
        grown = np.full((self.T, 2 * self.length, 2), np.nan)
        grown[:, : self.length] = self._history
        self._history = grown

    def _append(self, estimate: NDArray[np.float64]) -> None:
        if self.length == self._history.shape[1]:
            self._grow()
        self._history[:, self.length] = estimate
        self.length += 1

    def _resample(self) -> None:
        w = self.weights
        n_eff = 1.0 / np.einsum("tn,tn->t", w, w)
        low = self.started & (n_eff < self.resample_threshold * self.N)
        if not low.any():
            return
        rows = np.flatnonzero(low)
        u = self.rng.random(len(rows))
        if len(rows) == self.T:
            flat = systematic_resample_batch(w, u)
            self.particles = np.take(self.particles.reshape(-1, 2), flat, axis=0)
            self.weights.fill(1.0 / self.N)
        else:
            flat = systematic_resample_batch(w[rows], u)
            picked = np.take(self.particles[rows].reshape(-1, 2), flat, axis=0)
            self.particles[rows] = picked
            self.weights[rows] = 1.0 / self.N
        self.resampled += len(rows)


# the update arguments of a single-target frame without / with a measurement (never written)
_NO_Z = np.zeros((1, 2))
_HAS = (np.zeros(1, dtype=bool), np.ones(1, dtype=bool))


def agent_rng(seed: int | None) -> np.random.Generator:
    """The agent's own generator for ``seed``.

    Gymnasium seeds ``env.np_random`` as ``PCG64(SeedSequence(seed))``, which is exactly
    ``np.random.default_rng(seed)``: an agent reset with the same seed as its env would replay the
    env's measurement noise. A spawn key keeps the two streams independent.
    """
    if seed is None:
        return np.random.default_rng()
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0xA6E7,)))


class ParticleFilterAgent:
    """Single-target bootstrap particle filter agent ``"pf"`` (Jung et al. 2019; module docstring).

    Reports one track (id 0) at the weighted-mean estimate from the first detection on, with the
    detection row it was updated with (−1 when it only predicted).

    Args:
        n_particles: ``N`` (default 100).
        model: A name of
            [`predictors.displacement.DISPLACEMENT_MODELS`][predictors.displacement.DISPLACEMENT_MODELS]:
            ``"brownian"`` (default), ``"cv"``, ``"lstm"`` (the learned displacement model of Jung et al.
            2019,
            [`predictors.displacement_lstm.model.LSTMDisplacement`][predictors.displacement_lstm.model.LSTMDisplacement]);
            or a [`DisplacementModel`][predictors.displacement.base.DisplacementModel].
        model_weights: The ``displacement-lstm`` model file of ``model="lstm"`` (path with or
            without suffix); default the shipped weights trained on the noiseless sine.
        sigma_p: Process noise in multiples of ``step`` (default 1.0); used by the named models.
        sigma_m: Measurement noise of the likelihood in multiples of ``step``; default the sensor's
            ``noise_std`` (floored at ``0.05·step`` so that a noise-free sensor still weighs).
        sigma_0: Std of the initial cloud in multiples of ``step``; default ``sigma_m``.
        step: ``Δ`` in sensor units (default 0.2).
        resample_threshold: Resample when ``N_eff`` falls below this fraction of ``N`` (0.5).
        p_gate: Gate probability of the clutter gate (default 0.999).
        init_radius: With clutter, a start needs a previous-frame detection this close, in
            multiples of ``step`` (default 3).
        max_misses: With clutter, restart after this many gated-out frames in a row (default 10).
    """

    #: tracks one target: applies to single-target scenes only (see agents.agent_applies_to)
    traits = AgentTraits(max_targets=1)

    def __init__(
        self,
        *,
        n_particles: int = 100,
        model: str | DisplacementModel = "brownian",
        model_weights: str | os.PathLike[str] | None = None,
        sigma_p: float = 1.0,
        sigma_m: float | None = None,
        sigma_0: float | None = None,
        step: float = STEP,
        resample_threshold: float = 0.5,
        p_gate: float = 0.999,
        init_radius: float = 3.0,
        max_misses: int = 10,
    ):
        if not (isinstance(n_particles, int | np.integer) and n_particles >= 1):
            raise ValueError(f"n_particles must be an integer >= 1, got {n_particles!r}")
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"step must be a finite number > 0, got {step!r}")
        for name, value in (("sigma_m", sigma_m), ("sigma_0", sigma_0)):
            if value is not None:
                check_sigma(name, value)
        if not (isinstance(max_misses, int | np.integer) and max_misses >= 1):
            raise ValueError(f"max_misses must be an integer >= 1, got {max_misses!r}")
        if not (np.isfinite(init_radius) and init_radius > 0):
            raise ValueError(f"init_radius must be a finite number > 0, got {init_radius!r}")
        if not 0.0 < p_gate < 1.0:
            raise ValueError(f"p_gate must be in (0, 1), got {p_gate!r}")
        if not 0.0 <= resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must be in [0, 1], got {resample_threshold!r}")
        self.n_particles = int(n_particles)
        self.step = float(step)
        self.model = make_displacement_model(model, sigma_p, self.step, model_weights)
        self.sigma_m = sigma_m
        self.sigma_0 = sigma_0
        self.resample_threshold = float(resample_threshold)
        self.gate = -2.0 * np.log1p(-p_gate)  # χ²₂ quantile of p_gate
        self.init_radius = float(init_radius) * self.step
        self.max_misses = int(max_misses)
        self._previous = np.zeros((0, 2))
        self._misses = 0
        self._spec: SensorSpec | None = None
        self.filter: BatchParticleFilter | None = None

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start a new episode with the sensor ``spec``; every draw comes from
        [`agent_rng`][agents.particle.agent.agent_rng] (seed)."""
        if spec.dim != 2:
            raise ValueError(f"the particle filter tracks 2-D points, got a sensor of dim {spec.dim}")
        self._spec = spec
        self._previous = np.zeros((0, 2))
        self._misses = 0
        sm = self.sigma_m * self.step if self.sigma_m is not None else spec.noise_std
        sm = max(sm, 0.05 * self.step)
        s0 = self.sigma_0 * self.step if self.sigma_0 is not None else sm
        self.filter = BatchParticleFilter(
            1,
            self.n_particles,
            self.model,
            sigma_m=sm,
            sigma_0=s0,
            rng=agent_rng(seed),
            resample_threshold=self.resample_threshold,
        )

    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """Predict, update with the chosen detection (if any), and report the estimate."""
        if self._spec is None or self.filter is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        spec, pf = self._spec, self.filter
        rows, z = check_observation(obs, spec)
        clutter = spec.clutter_rate > 0
        m = len(rows)
        if pf.started[0] and (m == 0 or (m == 1 and not clutter)):
            # nothing to choose: predict and update in one call
            pick = m - 1
            estimate = pf.step(z if m else _NO_Z, _HAS[m])
        else:
            pick = self._choose(pf, z, clutter)
            estimate = pf.update(z[pick : pick + 1] if pick >= 0 else _NO_Z, _HAS[int(pick >= 0)])
        self._previous = z
        report = empty_report(spec.max_tracks, (2,))
        if pf.started[0]:  # one track, id 0, at the estimate
            report["positions"][0] = estimate[0]
            report["detection"][0] = rows[pick] if pick >= 0 else -1
            report["mask"][0] = 1
        return report

    def _choose(self, pf: BatchParticleFilter, z: NDArray[np.float64], clutter: bool) -> int:
        """Predict (a started filter) and pick the detection to update with: the gated nearest one,
        a confirmed one to (re)start on with clutter, the first otherwise; −1 for none."""
        pick = -1
        if pf.started[0]:
            pf.predict()
            if len(z) == 1 and not clutter:
                pick = 0
            elif len(z):
                pick = self._gated_nearest(z)
                self._misses = 0 if pick >= 0 else self._misses + 1
                if clutter and self._misses >= self.max_misses:
                    pf.started[0] = False
                    self._misses = 0
        if not pf.started[0] and len(z):
            pick = self._confirmed(z) if clutter else 0  # rows are shuffled by the env
        return pick

    def _confirmed(self, z: NDArray[np.float64]) -> int:
        """Index into ``z`` of the detection nearest to a previous-frame detection within
        ``init_radius``, or −1."""
        if not len(self._previous):
            return -1
        d = np.linalg.norm(z[:, None, :] - self._previous[None, :, :], axis=2).min(axis=1)
        best = int(np.argmin(d))
        return best if d[best] <= self.init_radius else -1

    def _gated_nearest(self, z: NDArray[np.float64]) -> int:
        """Index into ``z`` of the detection nearest to the predicted mean inside the gate, or −1."""
        assert self.filter is not None
        mean, cov = self.filter.moments()
        s = cov[0] + np.eye(2) * self.filter.sigma_m[0] ** 2
        d = z - mean[0]
        d2 = np.einsum("md,md->m", d, np.linalg.solve(s, d.T).T)
        best = int(np.argmin(d2))
        return best if d2[best] <= self.gate else -1
