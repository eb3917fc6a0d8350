"""The association step of a point tracker as a component: what it is given, what it returns.

A [`PointTracker`][agents.PointTracker] owns the track table and its life cycle
(predict, births, misses, deletion, the velocity prior, the nozzle-bar roll-out, the report);
every frame it hands its [`Associator`][agents.Associator] a read-only [`FrameContext`][agents.FrameContext] —
the predicted measurements ``N(ŷ_i, S_i)`` of the ``n`` live tracks, the ``m`` detections, the χ² gate and
what the tracker knows of its tracks — and gets back an [`Association`][agents.Association]: the detection of
every track (what the bookkeeping counts as seen), the measurement each track is updated with, and
which of the detections no track took may start a track. The associator then corrects the
predicted state ([`Associator.update`][agents.Associator.update]): the predictor's ``update`` for a hard
assignment, a mixture update for a probabilistic one.

Associators are registered by name ([`register_associator`][agents.register_associator],
[`make_associator`][agents.make_associator], [`available_associators`][agents.available_associators]), as
agents and predictors are; an unknown name raises a ``ValueError`` listing the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from predictors.base import Predictor
from track_envs.infra.declared import Declarations
from track_envs.infra.registry import Registry
from track_envs.values.types import Gaussian, SensorSpec


class AssociatorCapability(StrEnum):
    """What an associator may declare it does beyond the core
    (`ASSOCIATOR_DECLARATIONS`).

    * ``SECOND_CHANCE`` — it runs the capped second chance of leftover tracks and detections
      (`agents.tracking.second_chance`, its ``second_chance`` attribute), so
      it reads ``FrameContext.recovery_inflation``;
    * ``MIXTURE_UPDATE`` — it updates tracks by the moment-matched mixture of their hypotheses;
    * ``SHARED_DETECTIONS`` — several tracks may take one detection (a merged blob);
    * ``BIRTH_FILTER`` — it keeps some unclaimed detections from starting tracks
      (``Association.may_start``).
    """

    SECOND_CHANCE = "second-chance"
    MIXTURE_UPDATE = "mixture-update"
    SHARED_DETECTIONS = "shared-detections"
    BIRTH_FILTER = "birth-filter"


@dataclass(frozen=True)
class FrameContext:
    """What the tracker gives its associator in one frame (read-only: never write into the arrays).

    Attributes:
        prediction: Predicted measurements ``N(ŷ_i, S_i)`` of the ``n`` live tracks.
        predicted: (n, D) ``ŷ`` as C-contiguous float64.
        z: (m, D) float64 detections.
        gate: The χ² gate (squared Mahalanobis distance) at ``p_gate``.
        p_gate: The gate probability ``P_G``.
        recovery_inflation: Covariance scale of a second chance (1: none).
        noise: Sensor noise std the tracker assumes (``noise_scale`` times the declared one,
            at least 1 µm).
        noise_scale: Factor ``k`` on the declared noise std.
        streak: (n,) updates in a row of every track before this frame.
        last: (n, D) every track's last estimate (before this frame).
        motion: The stream's motion per frame ``‖v̄‖ dt`` by the velocity prior (0: no prior).
        region: ``(low, high)`` (D,) corners of the observed region grown by ``region_margin``.
        spec: The sensor.
    """

    prediction: Gaussian
    predicted: NDArray[np.float64]
    z: NDArray[np.float64]
    gate: float
    p_gate: float
    recovery_inflation: float
    noise: float
    noise_scale: float
    streak: NDArray[np.int64]
    last: NDArray[np.float64]
    motion: float
    region: tuple[NDArray[np.float64], NDArray[np.float64]]
    spec: SensorSpec


@dataclass(frozen=True)
class Association:
    """What an associator decided in one frame.

    Attributes:
        det_of_track: (n,) int64 detection index of every track, −1 for none: what the tracker
            counts as seen, reports, and leaves for births.
        measurements: (n, D) the measurement each seen track is updated with (rows of tracks
            without a detection are never read by a hard update).
        may_start: (m,) bool, which detections may start a track if no track took them; None:
            all of them.
        detail: Whatever else the associator's own [`Associator.update`][agents.Associator.update] reads (e.g.
            jpda's mixture), opaque to the tracker.
    """

    det_of_track: NDArray[np.int64]
    measurements: NDArray[np.float64]
    may_start: NDArray[np.bool_] | None = None
    detail: Any = None


@runtime_checkable
class Associator(Protocol):
    """A tracker's association step (module docstring). What it does beyond the core it declares
    in its class attribute ``capabilities`` (a frozenset of
    [`AssociatorCapability`][agents.AssociatorCapability]), asked with
    [`associator_capability`][agents.tracking.associator_capability]."""

    def reset(self, spec: SensorSpec, predictor: Predictor) -> None:
        """Start an episode with sensor ``spec``; ``predictor`` is the tracker's (for its
        capabilities)."""
        ...

    def associate(self, frame: FrameContext) -> Association:
        """The association of one frame with ``n >= 1`` live tracks."""
        ...

    def update(
        self, predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]
    ) -> Any:
        """The predicted ``state`` corrected with this frame's ``association`` (``seen``: the
        tracks the tracker counts as seen)."""
        ...

    def warm_up(self, dim: int) -> None:
        """Compile the kernels this associator uses that a tracker's warm-up stream does not reach."""
        ...


def hard_update(predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]) -> Any:
    """The predictor's ``update`` of the ``seen`` tracks by their measurement rows."""
    return predictor.update(state, association.measurements, seen)


class WithSecondChance(Associator, Protocol):
    """``SECOND_CHANCE``: the capped second chance it runs, with its gate-hit figures."""

    second_chance: Any


class _Declared(Associator, Protocol):
    """A capability that adds no member to the core (what the associator does, not what it has)."""


#: The capabilities of associators ([`track_envs.infra.declared`][track_envs.infra.declared]).
ASSOCIATOR_DECLARATIONS: Declarations[AssociatorCapability] = Declarations(
    AssociatorCapability,
    {
        AssociatorCapability.SECOND_CHANCE: WithSecondChance,
        AssociatorCapability.MIXTURE_UPDATE: _Declared,
        AssociatorCapability.SHARED_DETECTIONS: _Declared,
        AssociatorCapability.BIRTH_FILTER: _Declared,
    },
    core=Associator,
)


def associator_capability(associator: object, which: AssociatorCapability) -> Any:
    """``associator`` when its class declares capability ``which`` (its members checked), else
    ``None``: the one way to ask an associator what it offers."""
    return ASSOCIATOR_DECLARATIONS.get(associator, which)


def associator_declares(associator: object, which: AssociatorCapability) -> bool:
    """Whether ``associator``'s class (or a registered associator class) declares ``which``."""
    return ASSOCIATOR_DECLARATIONS.declares(associator, which)


ASSOCIATOR_REGISTRY = Registry("associator")


def register_associator(name: str, factory: Callable[..., Associator]) -> None:
    """Register ``factory`` (usually an associator class) under ``name`` (re-registering replaces it)."""
    ASSOCIATOR_REGISTRY.register(name, factory)


def available_associators() -> list[str]:
    """Names accepted by [`make_associator`][agents.make_associator]."""
    return ASSOCIATOR_REGISTRY.names()


def make_associator(name: str, **kwargs: Any) -> Associator:
    """The associator registered as ``name`` built with ``kwargs``.

    Raises:
        ValueError: for an unknown name, listing the valid names.
        UnknownArgumentError: for a keyword its factory does not take, listing those it takes.
    """
    associator: Associator = ASSOCIATOR_REGISTRY.make(name, **kwargs)
    return associator
