"""Particle displacement models: how a particle filter moves its particles one frame on.

* :mod:`~predictors.displacement.base`: the protocols (:class:`DisplacementModel`, the core,
  and :class:`CommonDisplacementModel`, the ``COMMON_DISPLACEMENT`` capability a model declares);
* :mod:`~predictors.displacement.models`: :class:`Brownian` and :class:`ConstantVelocityDisplacement`;
* :mod:`~predictors.displacement.registry`: :data:`DISPLACEMENT_MODELS` and
  :func:`make_displacement_model` (the learned model, ``"lstm"``, lives in
  :mod:`predictors.displacement_lstm`);
* :mod:`~predictors.displacement.geometry`: the relative displacement (rotation, speed) maths.
"""

from predictors.displacement.base import (
    DISPLACEMENT_DECLARATIONS,
    CommonDisplacementModel,
    DisplacementCapability,
    DisplacementModel,
    displacement_capability,
)
from predictors.displacement.models import STEP, Brownian, ConstantVelocityDisplacement, check_sigma
from predictors.displacement.registry import (
    DISPLACEMENT_MODELS,
    LEARNED_MODELS,
    make_displacement_model,
    motion_models,
)

__all__ = [
    "DISPLACEMENT_DECLARATIONS",
    "DISPLACEMENT_MODELS",
    "LEARNED_MODELS",
    "STEP",
    "Brownian",
    "CommonDisplacementModel",
    "ConstantVelocityDisplacement",
    "DisplacementCapability",
    "DisplacementModel",
    "check_sigma",
    "displacement_capability",
    "make_displacement_model",
    "motion_models",
]
