"""Particle displacement models: how a particle filter moves its particles one frame on.

* :mod:`~predictors.displacement.base`: the protocols (:class:`DisplacementModel`,
  :class:`CommonDisplacementModel`);
* :mod:`~predictors.displacement.models`: :class:`Brownian` and :class:`ConstantVelocityDisplacement`;
* :mod:`~predictors.displacement.registry`: :data:`DISPLACEMENT_MODELS` and
  :func:`make_displacement_model` (the learned model, ``"lstm"``, lives in
  :mod:`predictors.displacement_lstm`);
* :mod:`~predictors.displacement.geometry`: the relative displacement (rotation, speed) maths.
"""

from predictors.displacement.base import CommonDisplacementModel, DisplacementModel
from predictors.displacement.models import STEP, Brownian, ConstantVelocityDisplacement, check_sigma
from predictors.displacement.registry import (
    DISPLACEMENT_MODELS,
    LEARNED_MODELS,
    make_displacement_model,
    motion_models,
)

__all__ = [
    "DISPLACEMENT_MODELS",
    "LEARNED_MODELS",
    "STEP",
    "Brownian",
    "CommonDisplacementModel",
    "ConstantVelocityDisplacement",
    "DisplacementModel",
    "check_sigma",
    "make_displacement_model",
    "motion_models",
]
