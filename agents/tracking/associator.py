"""The association step of a point tracker as a component: what it is given, what it returns.

A :class:`~agents.tracking.tracker.PointTracker` owns the track table and its life cycle
(predict, births, misses, deletion, the velocity prior, the nozzle-bar roll-out, the report);
every frame it hands its :class:`Associator` a read-only :class:`FrameContext` — the predicted
measurements ``N(ŷ_i, S_i)`` of the ``n`` live tracks, the ``m`` detections, the χ² gate and what
the tracker knows of its tracks — and gets back an :class:`Association`: the detection of every
track (what the bookkeeping counts as seen), the measurement each track is updated with, and
which of the detections no track took may start a track. The associator then corrects the
predicted state (:meth:`Associator.update`): the predictor's ``update`` for a hard assignment, a
mixture update for a probabilistic one.

Associators are registered by name (:func:`register_associator`, :func:`make_associator`,
:func:`available_associators`), as agents and predictors are; an unknown name raises a
``ValueError`` listing the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from predictors.base import Predictor
from track_envs.infra.registry import Registry
from track_envs.values.types import Gaussian, SensorSpec

#: Capability: the associator runs the capped second chance of leftover tracks and detections
#: (:mod:`agents.tracking.second_chance`), so it reads ``FrameContext.recovery_inflation``.
SECOND_CHANCE = "second-chance"
#: Capability: it updates tracks by the moment-matched mixture of their hypotheses.
MIXTURE_UPDATE = "mixture-update"
#: Capability: several tracks may take one detection (a merged blob).
SHARED_DETECTIONS = "shared-detections"
#: Capability: it keeps some unclaimed detections from starting tracks (``Association.may_start``).
BIRTH_FILTER = "birth-filter"
#: Every capability an associator may declare in :attr:`Associator.offers`.
CAPABILITIES = frozenset({SECOND_CHANCE, MIXTURE_UPDATE, SHARED_DETECTIONS, BIRTH_FILTER})


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
        detail: Whatever else the associator's own :meth:`Associator.update` reads (e.g. jpda's
            mixture), opaque to the tracker.
    """

    det_of_track: NDArray[np.int64]
    measurements: NDArray[np.float64]
    may_start: NDArray[np.bool_] | None = None
    detail: Any = None


@runtime_checkable
class Associator(Protocol):
    """A tracker's association step (module docstring).

    Attributes:
        offers: The capabilities it declares (a subset of :data:`CAPABILITIES`).
    """

    offers: frozenset[str]

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


ASSOCIATOR_REGISTRY = Registry("associator")


def register_associator(name: str, factory: Callable[..., Associator]) -> None:
    """Register ``factory`` (usually an associator class) under ``name`` (re-registering replaces it)."""
    ASSOCIATOR_REGISTRY.register(name, factory)


def available_associators() -> list[str]:
    """Names accepted by :func:`make_associator`."""
    return ASSOCIATOR_REGISTRY.names()


def make_associator(name: str, **kwargs: Any) -> Associator:
    """The associator registered as ``name`` built with ``kwargs``.

    Raises:
        ValueError: for an unknown name, listing the valid names.
        UnknownArgumentError: for a keyword its factory does not take, listing those it takes.
    """
    associator: Associator = ASSOCIATOR_REGISTRY.make(name, **kwargs)
    return associator
