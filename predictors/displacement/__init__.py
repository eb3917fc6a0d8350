"""Particle displacement models: how a particle filter moves its particles one frame on.

* [`base`][predictors.displacement.base]: the protocols
([`DisplacementModel`][predictors.displacement.base.DisplacementModel], the core,
  and [`CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel], the
  ``COMMON_DISPLACEMENT`` capability a model declares);
* [`models`][predictors.displacement.models]: [`Brownian`][predictors.displacement.models.Brownian] and
[`ConstantVelocityDisplacement`][predictors.displacement.models.ConstantVelocityDisplacement];
* [`registry`][predictors.displacement.registry]:
[`DISPLACEMENT_MODELS`][predictors.displacement.DISPLACEMENT_MODELS] and
  [`make_displacement_model`][predictors.displacement.registry.make_displacement_model] (the learned model,
  ``"lstm"``, lives in [`predictors.displacement_lstm`][predictors.displacement_lstm]);
* [`geometry`][predictors.displacement.geometry]: the relative displacement (rotation, speed) maths.
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
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
