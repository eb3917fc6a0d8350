"""Motion models with uncertainty, batched over tracks (the Predictor protocol,
`predictors.base`).

Registry (`predictors.registry`): [`make_predictor`][predictors.make_predictor] builds
a predictor by name (an unknown name raises a ``ValueError`` that lists the valid ones);
[`resolve_predictor`][predictors.resolve_predictor] takes a name or a Predictor object, as a tracker's
``predictor`` argument does. `motion_models` lists every motion model of the three
kinds (Gaussian predictor, particle displacement, pose hypothesis) with the agents that take it.

Training recipes (`predictors.training.recipes`): each learned family registers
how ``track train KIND`` trains it beside its predictor ([`register_recipe`][predictors.register_recipe],
[`available_recipes`][predictors.available_recipes]); the families' modules, which import torch, load on first
use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from predictors.base import BatchState, Capability, Crossings, Predictor, capability, has_capability
from predictors.motion_models import KINDS, MotionModel, motion_models
from predictors.registry import (
    BELT_ENVS,
    PREDICTORS,
    available_predictors,
    make_predictor,
    predictor_applies_to,
    register_predictor,
    resolve_predictor,
)
from predictors.training.recipes import TrainingRecipe, available_recipes, register_recipe
from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.lstm_cell import LSTMCellWeights

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)


def kf_cv(
    *, q: float | None = None, initial_velocity_std: float | None = None, initial_velocity: Any = None
) -> Predictor:
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
) -> Predictor:
    """Constant-acceleration Kalman filter (white-noise jerk of intensity q), batched over tracks."""
    from predictors.kalman.predictor import KalmanPredictor

    return KalmanPredictor(
        "ca",
        q=q,
        initial_velocity_std=initial_velocity_std,
        initial_acceleration_std=initial_acceleration_std,
        initial_velocity=initial_velocity,
    )


def random_walk(*, q: float | None = None) -> Predictor:
    """Position-only random-walk Kalman filter (white-noise velocity of intensity q), batched."""
    from predictors.kalman.predictor import KalmanPredictor

    return KalmanPredictor("random-walk", q=q)


def lstm(*, weights: Any = None, particle_kind: str = "cylinder") -> Predictor:
    """Belt LSTM trained with MSE; covariance ``s·I`` with ``s`` line-searched on the tracker's e_mean.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("lstm", weights, particle_kind=particle_kind)


def nll_lstm(*, weights: Any = None, particle_kind: str = "cylinder") -> Predictor:
    """Belt LSTM with a heteroscedastic Gaussian output (mean, log-variance), calibrated covariances.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``: cylinder,
    sphere or cuboid).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("nll-lstm", weights, particle_kind=particle_kind)


def mc_lstm(*, weights: Any = None, particle_kind: str = "cylinder", samples: int = 250) -> Predictor:
    """Belt LSTM with variational MC dropout: ``samples`` masks per track, calibrated covariances.

    ``weights``: a model file (default: the shipped weights for ``particle_kind``).
    """
    from predictors.belt_lstm.predictor import LSTMPredictor

    return LSTMPredictor("mc-lstm", weights, particle_kind=particle_kind, samples=samples)


def _register_builtin() -> None:
    register_predictor("kf-cv", kf_cv)
    register_predictor("kf-ca", kf_ca)
    register_predictor("random-walk", random_walk)
    register_predictor("lstm", lstm, envs=BELT_ENVS)
    register_predictor("nll-lstm", nll_lstm, envs=BELT_ENVS)
    register_predictor("mc-lstm", mc_lstm, envs=BELT_ENVS)
    # the training recipes of the learned families (``track train KIND``, in this order): the belt
    # LSTMs above, the particle filter's displacement model ("lstm" of
    # predictors.displacement.registry) and the SMC pose tracker's predictor ("smc" of
    # predictors.pose.registry)
    for kind in ("lstm", "mc-lstm", "nll-lstm"):
        register_recipe(kind, "predictors.belt_lstm.recipe")
    register_recipe("displacement-lstm", "predictors.displacement_lstm.training")
    register_recipe("pose-lstm", "predictors.pose_lstm.training")


_register_builtin()
