"""Extending track-envs with a predictor: an alpha-beta filter over a batch of tracks.

One module and a ``register_predictor`` call. A predictor is a motion model with uncertainty,
batched over the ``n`` tracks of a tracker (the [`predictors.base.Predictor`][predictors.Predictor] protocol):

* ``reset(spec)`` binds it to the env's [`SensorSpec`][track_envs.SensorSpec] (``dt``, noise);
* ``start(z)`` makes the states of new tracks from their first measurements ``z`` (n, D);
* ``predict(state) -> (state, Gaussian)`` moves every track one frame on and gives its predicted
  measurement ``N(mean (n, D), cov (n, D, D))``, which the tracker gates and associates with;
* ``update(state, z, seen) -> state`` corrects the rows with ``seen`` True; the others coast;
* ``estimate(state) -> Gaussian`` is what the tracker reports.

The state is an immutable [`BatchState`][predictors.BatchState] (a frozen dataclass of arrays
whose first axis is the track), so the tracker keeps survivors with ``state.take(rows)`` and
appends births with ``type(state).concat([a, b])`` without knowing the fields.

Anything beyond the core is a declared capability (``capabilities = frozenset({...})``); this
filter declares one, ``VELOCITY_PRIOR``: ``start`` also takes a velocity prior, which gnn then
passes from the flow it learns online. A predictor that declares nothing works in every tracker
too. Run it::

    python examples/extend_predictor.py --steps 200
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from predictors import BatchState, Capability, register_predictor
from track_envs import Gaussian, SensorSpec

NAME = "alpha-beta"
FloatArray = NDArray[np.float64]


def alpha_beta_gains(tracking_index: float) -> tuple[float, float]:
    """The steady-state gains ``(α, β)`` of tracking index ``λ`` (Kalata 1984).

    ``λ = σ_a dt² / σ_n`` (manoeuvre over noise) fixes the steady-state Kalman filter of the
    constant-velocity model with piecewise-constant white acceleration of std ``σ_a``:

        α = −(λ² + 8λ − (λ + 4) √(λ² + 8λ)) / 8,    β = (λ² + 4λ − λ √(λ² + 8λ)) / 4.
    """
    lam = tracking_index
    root = math.sqrt(lam * lam + 8 * lam)
    return -(lam * lam + 8 * lam - (lam + 4) * root) / 8, (lam * lam + 4 * lam - lam * root) / 4


@dataclass(frozen=True)
class AlphaBetaState(BatchState):
    """Per-track state (first axis: tracks).

    Attributes:
        x: Position (n, D).
        v: Velocity (n, D), sensor units per second.
        P: Covariance of ``(position, velocity)`` of every axis, (n, D, 2, 2).
    """

    x: FloatArray
    v: FloatArray
    P: FloatArray


class AlphaBetaPredictor:
    """Constant-velocity alpha-beta filter: fixed gains, every axis on its own, batched over tracks.

    Each frame, per axis, with ``F = [[1, dt], [0, 1]]``, ``Q = σ_a² Γ Γᵀ``, ``Γ = [dt²/2, dt]ᵀ``
    and the fixed gain ``K = [α, β/dt]ᵀ`` (`alpha_beta_gains`)::

        predict:  x ← x + v dt,           P ← F P Fᵀ + Q,       ẑ ~ N(x, P₀₀ + σ_n²)
        update:   x ← x + α (z − x),     v ← v + (β/dt)(z − x),
                  P ← A P Aᵀ + σ_n² K Kᵀ  with  A = I − K [1, 0]   (Joseph form: exact for any gain)

    The gains are those the Kalman filter of the same model reaches in its steady state, so the
    covariance converges to the Kalman filter's; before that (a new track, a coasting one) it
    is the true covariance of this fixed-gain estimator, which is what the gate needs.

    Args:
        tracking_index: ``λ = σ_a dt² / σ_n`` > 0: the manoeuvre the filter follows, in units of
            the sensor noise (0.5: an acceleration of half the noise std per frame²).
        initial_velocity_std: Std of a new track's velocity per axis (sensor units / s) when no
            velocity prior is given, > 0.
    """

    #: The optional capabilities this predictor offers ([`predictors.base`][predictors.base]): gnn asks for
    #: them with ``capability(predictor, Capability.VELOCITY_PRIOR)``.
    capabilities: ClassVar[frozenset[Capability]] = frozenset({Capability.VELOCITY_PRIOR})

    def __init__(self, *, tracking_index: float = 0.5, initial_velocity_std: float = 1.0):
        for name, value in (
            ("tracking_index", tracking_index),
            ("initial_velocity_std", initial_velocity_std),
        ):
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        self.tracking_index = float(tracking_index)
        self.initial_velocity_std = float(initial_velocity_std)
        self.alpha, self.beta = alpha_beta_gains(self.tracking_index)
        self._dim = 0

    def reset(self, spec: SensorSpec) -> None:
        """Bind to ``spec``: the frame period, the dimension and the noise ``σ_n``."""
        dt, self._dim = float(spec.dt), int(spec.dim)
        self._r = max(float(spec.noise_std), 1e-6) ** 2
        sigma_a = self.tracking_index * math.sqrt(self._r) / dt**2
        gamma = np.array([dt * dt / 2, dt])
        self._F = np.array([[1.0, dt], [0.0, 1.0]])
        self._Q = sigma_a**2 * np.outer(gamma, gamma)
        K = np.array([self.alpha, self.beta / dt])
        self._K = K
        self._A = np.eye(2) - np.outer(K, [1.0, 0.0])
        self._KRK = self._r * np.outer(K, K)
        self._dt = dt

    def start(
        self,
        z: NDArray[np.floating],
        velocity: NDArray[np.floating] | None = None,
        velocity_cov: NDArray[np.floating] | None = None,
    ) -> AlphaBetaState:
        """New tracks at ``z`` (n, D), at rest with std ``initial_velocity_std``, or with the
        velocity prior ``N(velocity (n, D), velocity_cov (n, D, D))`` (its diagonal: the axes are
        independent here), the ``VELOCITY_PRIOR`` capability."""
        x = np.array(z, dtype=np.float64).reshape(-1, self._dim)
        n = len(x)
        v = np.zeros_like(x) if velocity is None else np.broadcast_to(velocity, x.shape).astype(np.float64)
        if velocity_cov is None:
            v_var = np.full((n, self._dim), self.initial_velocity_std**2)
        else:
            v_var = np.diagonal(np.broadcast_to(velocity_cov, (n, self._dim, self._dim)), axis1=1, axis2=2)
        P = np.zeros((n, self._dim, 2, 2))
        P[:, :, 0, 0] = self._r
        P[:, :, 1, 1] = v_var
        return AlphaBetaState(x, v, P)

    def predict(self, state: AlphaBetaState) -> tuple[AlphaBetaState, Gaussian]:
        """Every track one frame on, and its predicted measurement."""
        P = self._F @ state.P @ self._F.T + self._Q
        predicted = AlphaBetaState(state.x + state.v * self._dt, state.v, P)
        return predicted, self._gaussian(predicted.x, P[:, :, 0, 0] + self._r)

    def update(
        self, state: AlphaBetaState, z: NDArray[np.floating], seen: NDArray[np.bool_]
    ) -> AlphaBetaState:
        """Correct the rows with ``seen`` True by ``z`` (n, D); the others keep their prediction."""
        seen = np.asarray(seen, dtype=bool)
        innovation = np.where(seen[:, None], np.asarray(z, dtype=np.float64) - state.x, 0.0)
        P = np.where(seen[:, None, None, None], self._A @ state.P @ self._A.T + self._KRK, state.P)
        return AlphaBetaState(
            state.x + self.alpha * innovation, state.v + (self.beta / self._dt) * innovation, P
        )

    def estimate(self, state: AlphaBetaState) -> Gaussian:
        """Position and its covariance of every track."""
        return self._gaussian(state.x, state.P[:, :, 0, 0])

    @staticmethod
    def _gaussian(mean: FloatArray, variance: FloatArray) -> Gaussian:
        """``N(mean (n, D), diag(variance (n, D)))``."""
        return Gaussian(mean, variance[:, :, None] * np.eye(mean.shape[1]))


def register() -> None:
    """Register the filter as `NAME` (its keyword arguments are the factory's)."""
    register_predictor(NAME, AlphaBetaPredictor)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Check the filter against the Predictor protocol and track SineTarget-v0 with gnn."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="frames to track (default 200)")
    parser.add_argument("--tracking-index", type=float, default=0.5, help="λ = σ_a dt² / σ_n (default 0.5)")
    parser.add_argument("--clutter-rate", type=float, default=0.5, help="clutter per frame (default 0.5)")
    args = parser.parse_args(argv)

    import gymnasium as gym

    import track_envs  # noqa: F401  (registers the envs)
    from agents import make_agent, run_episode
    from predictors import make_predictor
    from track_envs.testing import check_predictor
    from track_envs.wrappers import TrackingMetrics

    register()
    # clutter starts tracks every few frames: gnn starts them with its learnt velocity prior
    base = gym.make(
        "SineTarget-v0", clutter_rate=args.clutter_rate, max_tracks=16, max_episode_steps=args.steps
    )
    env = TrackingMetrics(base)
    spec = env.get_wrapper_attr("sensor_spec")
    check_predictor(make_predictor(NAME), spec)
    agent = make_agent("gnn", predictor=NAME, tracking_index=args.tracking_index)
    metrics = run_episode(env, agent, seed=0).metrics
    print(f"SineTarget-v0 + gnn({NAME}), {args.steps} frames: mean error {metrics['mean_error']:.3f}")
    return metrics


if __name__ == "__main__":
    main()
