"""The particle displacement model: how a particle filter moves its particles one frame on.

A displacement model is the prediction step of a bootstrap particle filter that tracks ``T``
targets with ``N`` particles each
([`agents.particle.agent.BatchParticleFilter`][agents.particle.agent.BatchParticleFilter]). It differs from a
[`predictors.base.Predictor`][predictors.Predictor] in what it carries: no Gaussian per track, only a proposal
``x⁽ⁱ⁾ ← propose(x⁽ⁱ⁾, x*_{0:t−1})`` that moves every particle (T, N, 2) by a sampled displacement, given the
history of the filter's weighted-mean estimates ``x*`` (T, t, 2). The filter owns the particles and their
weights; the weights come from the measurement likelihood, never from the model.

The core and one optional capability, declared as every plug-in's are
([`track_envs.infra.declared`][track_envs.infra.declared]: the class attribute ``capabilities``, asked with
[`displacement_capability`][predictors.displacement.base.displacement_capability]; a model that declares
nothing runs everywhere on its core):

* [`DisplacementModel`][predictors.displacement.base.DisplacementModel] (the core): ``propose`` only; the
filter runs its numpy path.
* ``COMMON_DISPLACEMENT`` ([`CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel]):
one common displacement per target
  plus white noise, ``propose(x, h, rng) = x + displacement(h)[:, None, :] + std·ε``; the filter
  runs its compiled path and calls ``displacement`` once per frame. Brownian, constant velocity,
  the LSTM of Jung et al.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any, Literal, Protocol, overload, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.declared import Declarations


@runtime_checkable
class DisplacementModel(Protocol):
    """The prediction step of the filter: moves every particle one frame on."""

    def propose(
        self, particles: NDArray[np.float64], history: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """Predicted particles (T, N, 2) from ``particles`` (T, N, 2) and the history of weighted-mean
        estimates ``history`` (T, t, 2) (oldest first; NaN for frames before a target's filter
        started), drawing every random number from ``rng``."""
        ...


@runtime_checkable
class CommonDisplacementModel(DisplacementModel, Protocol):
    """A displacement model that moves every particle of a target by one common displacement plus
    white noise: ``propose(x, h, rng) = x + displacement(h)[:, None, :] + std·ε``, ``ε ~ N(0, I_2)``.

    The filter runs such models on its compiled path ([`agents.particle._kernels`][agents.particle._kernels])
    and calls [`displacement`][predictors.displacement.base.CommonDisplacementModel.displacement] exactly once
    per frame, before the update, with the history of all ``T`` targets; after a (re)start a target's history
    is NaN except its newest estimate.
    """

    #: ``σ_p·Δ``, the white-noise std per axis: a scalar or one per target (T,).
    std: NDArray[np.float64]

    def displacement(self, history: NDArray[np.float64]) -> NDArray[np.float64]:
        """Common displacement (T, 2) of every particle of each target this frame, finite (zeros
        where unknown), from the weighted-mean estimates ``history`` (T, t, 2), oldest first, NaN
        before a target's filter (re)started."""
        ...


class DisplacementCapability(StrEnum):
    """The optional capabilities a displacement model class may declare (module docstring)."""

    COMMON_DISPLACEMENT = "common-displacement"


#: The capabilities of displacement models ([`track_envs.infra.declared`][track_envs.infra.declared]).
DISPLACEMENT_DECLARATIONS: Declarations[DisplacementCapability] = Declarations(
    DisplacementCapability,
    {DisplacementCapability.COMMON_DISPLACEMENT: CommonDisplacementModel},
    core=DisplacementModel,
)


@overload
def displacement_capability(
    model: object, which: Literal[DisplacementCapability.COMMON_DISPLACEMENT]
) -> CommonDisplacementModel | None: ...
@overload
def displacement_capability(model: object, which: DisplacementCapability) -> Any: ...
def displacement_capability(model: object, which: DisplacementCapability) -> Any:
    """``model``, typed as the protocol of capability ``which``, when its class declares it; else
    ``None`` (the one way the particle filter asks; module docstring).

    Raises:
        TypeError: if the class declares ``which`` but lacks a member of its protocol (named).
    """
    return DISPLACEMENT_DECLARATIONS.get(model, which)
