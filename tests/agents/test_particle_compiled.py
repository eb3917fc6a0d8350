"""The compiled frame of the particle filter (agents/particle/_kernels.py) against the numpy path."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import agents.particle.agent as particle
import track_envs  # noqa: F401
from agents import make_agent
from agents.particle._kernels import log_likelihood, resample_rows, systematic_indices, update_rows
from agents.particle.agent import BatchParticleFilter, systematic_resample, systematic_resample_batch
from predictors.displacement import (
    Brownian,
    CommonDisplacementModel,
    ConstantVelocityDisplacement,
    DisplacementModel,
)


class ProposeOnly:
    """A model with ``propose`` only: the filter runs the numpy path with the wrapped model's draws."""

    def __init__(self, model: DisplacementModel):
        self.model = model

    def propose(self, particles, history, rng):
        return self.model.propose(particles, history, rng)


def scene(n_targets: int, frames: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(frames) * 0.2
    truth = np.stack([t, np.sin(t)], axis=1)
    z = truth[:, None, :] + rng.normal(0.0, 0.1, (frames, n_targets, 2))
    has = rng.random((frames, n_targets)) < 0.7
    has[:3] = False  # the filters start at different frames
    return z, has


def run(model, n_targets, n_particles, z, has, seed=1):
    pf = BatchParticleFilter(
        n_targets, n_particles, model, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(seed)
    )
    estimates = np.array([pf.step(z[f], has[f]) for f in range(len(z))])
    return pf, estimates


def test_named_models_take_the_compiled_path_and_others_the_numpy_path():
    for model in (Brownian(), ConstantVelocityDisplacement()):
        assert isinstance(model, CommonDisplacementModel)
        assert BatchParticleFilter(1, 5, model, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng()).fused
    wrapped = ProposeOnly(Brownian())
    assert isinstance(wrapped, DisplacementModel) and not isinstance(wrapped, CommonDisplacementModel)
    pf = BatchParticleFilter(1, 5, wrapped, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng())
    assert not pf.fused
    pf.model = Brownian()
    assert pf.fused


@pytest.mark.parametrize("model_cls", [Brownian, ConstantVelocityDisplacement])
@pytest.mark.parametrize("n_targets, n_particles", [(1, 10), (3, 50), (3, 1000)])
def test_compiled_frame_equals_the_numpy_path(model_cls, n_targets, n_particles):
    """Same draws in the same order (the generators end in the same state), the same resampling,
    and weights, particles and estimates equal to rounding; (3, 1000) draws its prediction noise
    inside the kernel."""
    z, has = scene(n_targets, 60)
    sigma_p = np.linspace(0.5, 2.0, n_targets)
    fused, est_fused = run(model_cls(sigma_p), n_targets, n_particles, z, has)
    numpy_path, est_numpy = run(ProposeOnly(model_cls(sigma_p)), n_targets, n_particles, z, has)
    assert fused.fused and not numpy_path.fused
    assert fused.rng.bit_generator.state == numpy_path.rng.bit_generator.state
    assert fused.resampled == numpy_path.resampled > 0
    np.testing.assert_array_equal(np.isnan(est_fused), np.isnan(est_numpy))
    np.testing.assert_allclose(est_fused, est_numpy, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fused.particles, numpy_path.particles, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fused.weights, numpy_path.weights, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fused.history, numpy_path.history, rtol=0, atol=1e-12)


def test_drawing_inside_or_outside_the_kernel_gives_the_same_filter(monkeypatch):
    z, has = scene(4, 40)
    results = []
    for threshold in (1, 10**9):  # every size draws inside the kernel / none does
        monkeypatch.setattr(particle, "RNG_IN_KERNEL_PARTICLES", threshold)
        pf, est = run(ConstantVelocityDisplacement(0.7), 4, 64, z, has)
        assert pf._rng_in_kernel == (threshold == 1)
        results.append((est, pf.particles, pf.weights, pf.rng.random()))
    for a, b in zip(*results, strict=True):
        np.testing.assert_array_equal(a, b)


def test_separate_predict_and_update_equal_step():
    """The agent predicts, gates, then updates; that is the same frame as one step."""
    z, has = scene(2, 30)
    pf_step, est_step = run(Brownian(), 2, 40, z, has)
    pf = BatchParticleFilter(2, 40, Brownian(), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(1))
    est = []
    for f in range(len(z)):
        pf.predict()
        est.append(pf.update(z[f], has[f]))
    np.testing.assert_array_equal(np.array(est), est_step)
    np.testing.assert_array_equal(pf.particles, pf_step.particles)


def sequential_systematic(w, u):
    """The textbook merge (filterpy's loop, the last index where rounding runs past the end)."""
    n, cumsum, out, j = len(w), np.cumsum(w), [], 0
    for k in range(n):
        while j < n - 1 and (u + k) / n >= cumsum[j]:
            j += 1
        out.append(j)
    return np.array(out)


@pytest.mark.parametrize("seed", range(60))
def test_compiled_resampling_equals_the_sequential_rule(seed):
    """Weights on the grid of positions (ties between p_k and cumsum_j), degenerate and spiky ones."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 300))
    kind = seed % 3
    if kind == 0:  # multiples of 1/n: cumulative sums on the positions for u = 0
        w = rng.integers(0, 4, n).astype(float)
    elif kind == 1:  # one or two particles carry (almost) everything
        w = np.full(n, 1e-300)
        w[rng.integers(0, n, 2)] = 1.0
    else:
        w = rng.random(n) ** 8
    w[0] += 1.0
    w /= w.sum()
    for u in (0.0, 0.5, float(rng.random()), np.nextafter(1.0, 0.0)):
        out = np.empty(n, np.intp)
        systematic_indices(w, u, out)
        np.testing.assert_array_equal(out, sequential_systematic(w, u))


@pytest.mark.parametrize("seed", range(30))
def test_compiled_resampling_equals_the_numpy_rule(seed):
    """The numpy rule equals filterpy's bit for bit (test_particle.py); so does the compiled one."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    w = rng.random(n) ** int(rng.integers(1, 12))
    w[rng.random(n) < 0.3] = 0.0
    w[-1] += 1e-3
    w /= w.sum()
    for u in (0.0, float(rng.random()), np.nextafter(1.0, 0.0)):
        out = np.empty(n, np.intp)
        systematic_indices(w, u, out)
        np.testing.assert_array_equal(out, systematic_resample(w, u))


def test_compiled_row_resampling_equals_the_batched_numpy_resampling():
    rng = np.random.default_rng(3)
    w = rng.random((5, 80)) ** 4
    w /= w.sum(axis=1, keepdims=True)
    particles = rng.normal(size=(5, 80, 2))
    low = np.array([True, False, True, True, False])
    u = rng.random(3)
    expected = particles.copy()
    flat = systematic_resample_batch(w[low], u)
    expected[low] = np.take(particles[low].reshape(-1, 2), flat, axis=0)
    weights = w.copy()
    resample_rows(particles, weights, low, u)
    np.testing.assert_array_equal(particles, expected)
    np.testing.assert_array_equal(weights[low], 1.0 / 80)
    np.testing.assert_array_equal(weights[~low], w[~low])


def test_compiled_update_equals_equation_4_and_the_weighted_mean():
    rng = np.random.default_rng(5)
    t, n, sigma_m = 3, 200, 0.3
    particles = rng.normal(size=(t, n, 2))
    prior = rng.random((t, n))
    prior /= prior.sum(axis=1, keepdims=True)
    z = rng.normal(size=(t, 2))
    has = np.array([True, False, True])
    weights = prior.copy()
    estimate, new, low = np.empty((t, 2)), np.zeros(t, bool), np.zeros(t, bool)
    started = np.ones(t, bool)
    lik = np.full((t, n), np.nan)
    log_likelihood(particles, started, z, has, np.full(t, 0.5 / sigma_m**2), lik)
    assert (lik[has] <= 0).all() and (lik[has].max(axis=1) == 0).all() and (lik[~has] == 0).all()
    n_low = update_rows(
        particles, weights, started, z, has, np.exp(lik), np.zeros((0, n, 2)), np.full(t, 0.1), 0.5,
        estimate, new, low,
    )  # fmt: skip
    lik = np.exp(-((particles - z[:, None]) ** 2).sum(axis=2) / (2 * sigma_m**2))
    expected = np.where(has[:, None], prior * lik, prior)
    expected /= expected.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(weights, expected, rtol=1e-12, atol=0)
    np.testing.assert_allclose(estimate, np.einsum("tn,tnd->td", expected, particles), rtol=0, atol=1e-12)
    n_eff = 1.0 / (expected**2).sum(axis=1)
    np.testing.assert_array_equal(low, n_eff < 0.5 * n)
    assert n_low == low.sum() and not new.any()


def test_underflowed_prior_keeps_the_likelihood():
    """Every prior weight zero against the likelihood: the compiled update, like the numpy one, keeps
    the likelihood instead of dividing by zero."""
    particles = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    weights = np.array([[0.0, 0.0]])
    estimate, new, low = np.empty((1, 2)), np.zeros(1, bool), np.zeros(1, bool)
    lik = np.exp(-0.5 * np.array([[0.04, 0.64]]))
    update_rows(
        particles, weights, np.ones(1, bool), np.array([[0.2, 0.0]]), np.ones(1, bool), lik,
        np.zeros((0, 2, 2)), np.ones(1), 0.5, estimate, new, low,
    )  # fmt: skip
    np.testing.assert_allclose(weights[0], lik[0] / lik.sum(), rtol=1e-14)
    np.testing.assert_allclose(estimate[0], [lik[0, 1] / lik.sum(), 0.0], rtol=1e-14)


def test_compiled_filter_is_deterministic_per_seed():
    z, has = scene(3, 40)
    a = run(ConstantVelocityDisplacement(), 3, 300, z, has, seed=4)[1]
    b = run(ConstantVelocityDisplacement(), 3, 300, z, has, seed=4)[1]
    c = run(ConstantVelocityDisplacement(), 3, 300, z, has, seed=5)[1]
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a[5:], c[5:])


def test_agent_equals_the_agent_on_the_numpy_path():
    """The agent's one-pass frame (no choice to make) draws what predict + update did."""
    reports = []
    for model in (Brownian(), ProposeOnly(Brownian())):
        env = gym.make("SineTarget-v0", p_detect=0.6, periods=1.0)
        agent = make_agent("pf", model=model, n_particles=300)
        obs, _ = env.reset(seed=2)
        agent.reset(env.unwrapped.sensor_spec, seed=2)
        out = []
        for _ in range(25):
            report = agent.act(obs)
            out.append(report)
            obs, *_ = env.step(report)
        reports.append(out)
    for x, y in zip(*reports, strict=True):
        np.testing.assert_array_equal(x["detection"], y["detection"])
        np.testing.assert_allclose(x["positions"], y["positions"], rtol=1e-6)


class BadDisplacement(Brownian):
    def __init__(self, value):
        super().__init__(1.0)
        self.value = value

    def displacement(self, history):
        return self.value


@pytest.mark.parametrize(
    "value, match",
    [
        (np.zeros((1, 3)), r"shape \(2, 2\)"),
        (np.zeros(2), r"shape \(2, 2\)"),
        (np.full((2, 2), np.nan), "finite"),
    ],
)
def test_bad_displacement_is_named(value, match):
    pf = BatchParticleFilter(
        2, 5, BadDisplacement(value), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0)
    )
    with pytest.raises(ValueError, match=f"BadDisplacement.displacement.*{match}"):
        pf.step(np.zeros((2, 2)), np.ones(2, bool))


def test_bad_std_is_named():
    model = Brownian(np.ones(3))
    pf = BatchParticleFilter(2, 5, model, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"Brownian.std must be a scalar or have 2 entries"):
        pf.step(np.zeros((2, 2)), np.ones(2, bool))


class CountingConstantVelocity(ConstantVelocityDisplacement):
    """Records the history every displacement() call sees."""

    def __init__(self):
        super().__init__(0.5)
        self.seen = []

    def displacement(self, history):
        self.seen.append(history.copy())
        return super().displacement(history)


def test_displacement_is_called_once_per_frame_with_the_history_before_the_update():
    z, has = scene(2, 12)
    has[:] = True
    model = CountingConstantVelocity()
    pf = BatchParticleFilter(2, 30, model, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    for f in range(6):
        pf.step(z[f], has[f])
    for f in range(6, 12):  # the agent's way: predict, choose, update
        pf.predict()
        pf.update(z[f], has[f])
    assert len(model.seen) == 12
    for f, history in enumerate(model.seen):
        assert history.shape == (2, f, 2)
        np.testing.assert_array_equal(history, pf.history[:, :f])


def test_restarted_target_shows_the_model_a_history_of_nan_but_its_newest_estimate():
    model = CountingConstantVelocity()
    pf = BatchParticleFilter(1, 50, model, sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    for _ in range(4):
        pf.step(np.zeros((1, 2)), np.array([True]))
    pf.started[:] = False
    pf.step(np.array([[5.0, 5.0]]), np.array([True]))
    pf.step(np.array([[5.0, 5.0]]), np.array([True]))
    history = model.seen[-1]
    assert history.shape == (1, 5, 2)
    assert np.isnan(history[0, :4]).all() and np.isfinite(history[0, 4]).all()
    np.testing.assert_array_equal(model.displacement(history), np.zeros((1, 2)))


@pytest.mark.parametrize("rng", [np.random.RandomState(0), 0, None])
def test_rng_must_be_a_generator(rng):
    with pytest.raises(ValueError, match=r"rng must be a numpy\.random\.Generator"):
        BatchParticleFilter(1, 5, Brownian(), sigma_m=0.1, sigma_0=0.1, rng=rng)
