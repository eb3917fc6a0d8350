"""Motion models with uncertainty, batched over tracks (the Predictor protocol).

Registry: :func:`make_predictor` builds a predictor by name; an unknown name raises a
``ValueError`` that lists the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from track_envs.registry import Registry

PREDICTORS = Registry("predictor")


def register_predictor(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
    PREDICTORS.register(name, factory)


def available_predictors() -> list[str]:
    """Names accepted by :func:`make_predictor`."""
    return PREDICTORS.names()


def predictor_applies_to(name: str, env_id: str) -> bool:
    """Whether predictor ``name`` is meant for ``env_id``.

    A factory may declare ``envs``, the env ids its model was made for (the belt LSTMs: the belt
    envs, whose geometry and motion their weights learnt); factories without it apply to every
    point env.
    """
    envs = getattr(PREDICTORS.factory(name), "envs", None)
    return envs is None or env_id in envs


#: The env ids of the optical belt, where the belt LSTMs apply.
BELT_ENVS = ("BeltSorter-v0", "BeltReplay-v0")


def make_predictor(name: str, **kwargs: Any) -> Any:
    """Build the predictor registered as ``name`` (an unknown name raises ``ValueError`` listing them)."""
    return PREDICTORS.make(name, **kwargs)


def kf_cv(
    *, q: float | None = None, initial_velocity_std: float | None = None, initial_velocity: Any = None
) -> Any:
    """Constant-velocity Kalman filter (white-noise acceleration of intensity q), batched over tracks."""
    from predictors.kalman.predictor import KalmanPredictor

    return KalmanPredictor(
        "cv", q=q, initial_velocity_std=initial_velocity_std, initial_velocity=initial_velocity
    )


def kf_ca(
    *,
    q: float | None = None,
    initial_velocity_std: float | None = None,
    initial_acceleration_std: float | None = None,
    initial_velocity: Any = None,
) -> Any:
    """Constant-acceleration Kalman filter (white-noise jerk of intensity q), batched over tracks."""
    from predictors.kalman.predictor import KalmanPredictor

    return KalmanPredictor(
        "ca",
        q=q,
        initial_velocity_std=initial_velocity_std,
        initial_acceleration_std=initial_acceleration_std,
        initial_velocity=initial_velocity,
    )


def random_walk(*, q: float | None = None) -> Any:
    """Position-only random-walk Kalman filter (white-noise velocity of intensity q), batched."""
    from predictors.kalman.predictor import KalmanPredictor

    return KalmanPredictor("random-walk", q=q)


def lstm(*, weights: Any = None, particle_kind: str = "cylinder") -> Any:
    """Belt LSTM trained with MSE; covariance ``s·I`` with ``s`` line-searched on the tracker's e_mean.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("lstm", weights, particle_kind=particle_kind)


def nll_lstm(*, weights: Any = None, particle_kind: str = "cylinder") -> Any:
    """Belt LSTM with a heteroscedastic Gaussian output (mean, log-variance), calibrated covariances.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``: cylinder,
    sphere or cuboid).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("nll-lstm", weights, particle_kind=particle_kind)


def mc_lstm(*, weights: Any = None, particle_kind: str = "cylinder", samples: int = 250) -> Any:
    """Belt LSTM with variational MC dropout: ``samples`` masks per track, calibrated covariances.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("mc-lstm", weights, particle_kind=particle_kind, samples=samples)


for _factory in (lstm, nll_lstm, mc_lstm):
    _factory.envs = BELT_ENVS  # type: ignore[attr-defined]


def _register_builtin() -> None:
    register_predictor("kf-cv", kf_cv)
    register_predictor("kf-ca", kf_ca)
    register_predictor("random-walk", random_walk)
    register_predictor("lstm", lstm)
    register_predictor("nll-lstm", nll_lstm)
    register_predictor("mc-lstm", mc_lstm)


_register_builtin()
