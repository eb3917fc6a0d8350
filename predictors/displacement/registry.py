"""The registry of particle displacement models by name, and the factory the ``pf`` agent uses.

``make_agent("pf", model=NAME)`` and the experiments of Jung et al. (2019)
([`track_apps.reproductions.jung2019`][track_apps.reproductions.jung2019]) build their displacement model with
[`make_displacement_model`][predictors.displacement.registry.make_displacement_model]: ``"brownian"``
([`Brownian`][predictors.displacement.models.Brownian]), ``"cv"``
([`ConstantVelocityDisplacement`][predictors.displacement.models.ConstantVelocityDisplacement]) or ``"lstm"``
([`predictors.displacement_lstm.model.LSTMDisplacement`][predictors.displacement_lstm.model.LSTMDisplacement],
the one learned model: it takes a model file). Every factory takes ``(sigma_p, step)``; a learned one also
``weights``.
"""

from __future__ import annotations

import os
from typing import Any

from numpy.typing import ArrayLike

from predictors.displacement.base import DisplacementModel
from predictors.displacement.models import Brownian, ConstantVelocityDisplacement
from track_envs.infra.registry import Registry, missing_methods

#: The kind of model this registry holds (one of the three kinds of motion model).
KIND = "displacement"
#: The agents that take a displacement model (``make_agent("pf", model=NAME)``).
AGENTS = ("pf",)


def lstm(sigma_p: ArrayLike, step: float, weights: str | os.PathLike[str] | Any = None) -> Any:
    """The learned displacement model of Jung et al. (2019)
    ([`predictors.displacement_lstm.model`][predictors.displacement_lstm.model])."""
    from predictors.displacement_lstm.model import LSTMDisplacement

    return LSTMDisplacement(weights, sigma_p, step)


#: Displacement model factories by name; ``factory(sigma_p, step)`` (learned: ``weights`` too).
DISPLACEMENT_MODELS = Registry("model")
DISPLACEMENT_MODELS.register("brownian", Brownian)
DISPLACEMENT_MODELS.register("cv", ConstantVelocityDisplacement)
DISPLACEMENT_MODELS.register("lstm", lstm)
#: The named models that take a model file (``model_weights`` of the ``pf`` agent).
LEARNED_MODELS = ("lstm",)


def make_displacement_model(
    model: str | DisplacementModel, sigma_p: ArrayLike, step: float, weights: Any = None
) -> Any:
    """A model by name (``"brownian"``, ``"cv"``, ``"lstm"``) or the object itself.

    Args:
        model: A name of [`DISPLACEMENT_MODELS`][predictors.displacement.registry.DISPLACEMENT_MODELS] or a
            [`DisplacementModel`][predictors.displacement.base.DisplacementModel].
        sigma_p: Process noise in multiples of ``step`` (named models), scalar or one per target.
        step: ``Δ`` in trajectory units (named models).
        weights: The model file of a learned model (``"lstm"``; ``None``: its shipped weights).

    Raises:
        ValueError: an unknown name (listing the valid ones), ``weights`` for a model that takes
            none, or an object without ``propose``.
    """
    if isinstance(model, str):
        factory = DISPLACEMENT_MODELS.factory(model)
        if model in LEARNED_MODELS:
            return factory(sigma_p, step, weights)
        if weights is not None:
            raise ValueError(
                f"model_weights={weights!r} is for a learned model {list(LEARNED_MODELS)}, "
                f"not model={model!r}"
            )
        return factory(sigma_p, step)
    if weights is not None:
        raise ValueError(f"model_weights={weights!r} is for a learned model by name, not model={model!r}")
    if missing_methods(model, DisplacementModel):
        raise ValueError(
            f"model must be a name in {DISPLACEMENT_MODELS.names()} or have propose(), got {model!r}"
        )
    return model


def motion_models() -> list[tuple[str, str, tuple[str, ...]]]:
    """Every registered displacement model as ``(name, kind, agents that take it)``."""
    return [(name, KIND, AGENTS) for name in DISPLACEMENT_MODELS.names()]
