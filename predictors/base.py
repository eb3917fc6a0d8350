"""The Predictor protocol, its optional capabilities, and the batched state every predictor keeps.

A predictor is a motion model with uncertainty, batched over ``n`` tracks. The tracker owns the
state (an immutable value) and calls, each frame,

1. ``predict(state) -> (state, Gaussian)``: move every track one frame on and return the predicted
   measurement ``N(mean (n, D), cov (n, D, D))`` used for gating and association;
2. ``update(state, z, seen) -> state``: correct the tracks with ``seen[i]`` True by ``z[i]``; the
   others coast (their predicted state is kept);
3. ``estimate(state) -> Gaussian``: the current estimate, which the tracker reports;
4. ``start(z) -> state`` for new tracks, ``state.take(rows)`` for survivors and
   ``type(state).concat([a, b])`` to append births.

``reset(spec)`` binds the predictor to an environment's [`SensorSpec`][track_envs.SensorSpec]
(frame period, measurement noise, dimension) before the first ``start``. These five methods are
the core ([`Predictor`][predictors.Predictor]): a predictor with only them works in every Gaussian tracker
(gnn, one-step, the sorting roll-out).

Optional capabilities
---------------------
Anything beyond the core is a *capability*: a predictor class declares what it offers in its class
attribute ``capabilities: frozenset[Capability]`` (none when absent), and a tracker asks for one in
exactly one way, [`capability`][predictors.capability] (or [`has_capability`][predictors.has_capability]),
which returns the predictor typed as the capability's protocol, or ``None``. Trackers never probe a method
name, a signature or a concrete class. The declaration is read from the class, so a wrapper object declares
its own.

* ``NOISE_SCALE`` ([`NoiseScale`][predictors.base.NoiseScale]) — ``set_noise_scale(k: float) -> None``: assume
the
  measurement noise ``R = (k σ)² I`` from now on. Used by gnn's live ``noise_scale`` knob
  (GateTuning-v0). Kalman filters.
* ``VELOCITY_PRIOR`` ([`VelocityPrior`][predictors.base.VelocityPrior]) —
``start(z, velocity=None, velocity_cov=None)``:
  new tracks with a kinematic prior ``N(velocity (n, D), velocity_cov (n, D, D))``. Used by gnn
  (its learnt flow) and one-step (the mean first velocity). Kalman filters.
* ``MEAN_ONLY_ESTIMATE`` ([`MeanOnlyEstimate`][predictors.base.MeanOnlyEstimate]) —
``estimate_mean(state) -> (n, D)``: the
  mean of ``estimate`` without its covariance. Used by gnn every frame. Kalman filters.
* ``FUSED_SURVIVORS_BIRTHS`` ([`FusedSurvivorsBirths`][predictors.base.FusedSurvivorsBirths]) —
``survivors_and_births(state,
  keep, n_keep, z, velocity=None, velocity_cov=None) -> state``:
  ``concat([state.take(keep), start(z, ...)])`` in one pass, one prior ``velocity`` (D,),
  ``velocity_cov`` (D, D) for all births. Used by gnn's births and deletions. Kalman filters,
  belt LSTMs.
* ``LINE_ROLLOUT`` ([`LineRollout`][predictors.base.LineRollout]) —
``rollout_crossings(state, line, frame, dt,
  max_steps) -> (ok, mean, cov) | None``: the crossings of ``x = line`` that the frame-by-frame
  roll-out finds, in one compiled pass (``None`` where that pass does not apply); and the class
  attribute ``rollout_covariance``: ``"state"`` (``estimate`` after coasting carries the
  multi-step covariance) or ``"accumulate"`` (it is only the one-step prediction, so the roll-out
  sums the one-step covariances). Used by the sorting roll-out
  ([`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings]). Kalman filters (closed
  form, [`predictors.kalman.rollout`][predictors.kalman.rollout]), belt LSTMs.
* ``COAST`` ([`Coast`][predictors.base.Coast]) — ``coast(state) -> (state, Gaussian)``: ``predict`` then
  ``update`` with nothing seen, in one call, returning the prediction. Used by the sorting
  roll-out. Belt LSTMs.
* ``CALIBRATION`` ([`Calibrated`][predictors.base.Calibrated]) — ``calibration_scale: float``: the factor
``r`` the
  predicted covariances were calibrated by (1: uncalibrated). Used by one-step, whose raw
  reliability curve divides it out. Belt LSTMs.
* ``MIXTURE_UPDATE`` ([`MixtureUpdate`][predictors.base.MixtureUpdate]) —
``update_mixture(state, z_mean, z_spread,
  p_seen) -> state``: the moment-matched update by a mixture of measurements (probabilistic data
  association): with probability ``1 − p`` the track was not detected (it coasts), else it was
  detected with a measurement of mean ``z̄`` and spread ``Σ``; the state is the single Gaussian
  that matches the mixture's first two moments. Used by jpda. Kalman filters (Bar-Shalom's PDA
  update, exact); without it jpda falls back to ``update`` by the mixture's mean.
* ``TRANSLATE`` ([`Translate`][predictors.base.Translate]) — ``translate(state, offset) -> state``: every
track moved
  by ``offset`` (n, D) in measurement space, its motion unchanged (a blob that fell apart hands its
  track to one piece without a velocity jump). Used by jpda. Kalman filters, belt LSTMs.
* ``RANDOM_STREAM`` ([`RandomStream`][predictors.base.RandomStream]) — ``reset(spec, *, rng=None)``: the
random stream
  the predictor draws from (e.g. MC-dropout masks), derived by the tracker from its seed, so the
  same seed gives the same report. Used by every tracker's reset
  ([`reset_predictor`][predictors.base.reset_predictor]). Belt LSTMs.
* ``KINEMATIC_MODEL`` ([`KinematicModel`][predictors.base.KinematicModel]) — ``order: int`` and
``kinematic_model(dim, dt,
  q) -> (F, Q, H)``: the predictor is a linear Kalman filter of an ``order``-fold integrator per
  axis (1: random walk, 2: constant velocity, 3: constant acceleration) driven by white noise of
  intensity ``q``, and its factory takes the keyword ``q`` (with ``order >= 2`` also
  ``initial_velocity`` and ``initial_velocity_std``, with ``order == 3``
  ``initial_acceleration_std``). Used by the sensor model estimate
  ([`agents.sensor_model`][agents.sensor_model]), which estimates those settings. Kalman filters.

A capability is a promise of the same numbers as the core calls would give where both apply
(``coast`` equals ``predict`` + ``update``, ``survivors_and_births`` equals take/start/concat,
``rollout_crossings`` equals the frame-by-frame roll-out), so a tracker may always fall back to
the core. Declaring a capability without its members is a ``TypeError`` at the first
[`capability`][predictors.capability] call, naming what is missing.

The same five calls fit a Kalman filter (mean and covariance per track), an LSTM (hidden state
per track, carried and never re-run over a window), an MC-dropout LSTM (dropout masks fixed per
track inside the state), an NLL-LSTM (predicted variance) and a per-keypoint particle predictor:
each keeps whatever it needs per track in the fields of its [`BatchState`][predictors.BatchState].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from enum import StrEnum
from typing import Any, Literal, NamedTuple, Protocol, Self, overload, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.declared import Declarations
from track_envs.values.types import Gaussian, SensorSpec


@dataclass(frozen=True)
class BatchState:
    """Base of per-track predictor states: every field is an array whose first axis is the track.

    Subclasses only declare fields; [`take`][predictors.BatchState.take],
    [`concat`][predictors.BatchState.concat] and ``len`` work on all of them.
    """

    def __len__(self) -> int:
        return int(np.shape(getattr(self, _field_names(type(self))[0]))[0])

    def take(self, rows: NDArray[np.integer] | NDArray[np.bool_]) -> Self:
        """The tracks at ``rows`` (integer indices or a boolean mask); each field keeps its type.

        numpy fields stay numpy arrays and torch fields stay torch tensors (on their device).
        """
        names = _field_names(type(self))
        values = [getattr(self, name) for name in names]
        if all(type(v) is np.ndarray for v in values):
            index = np.asarray(rows)
            if index.dtype == np.bool_ and index.shape == (len(values[0]),):
                index = np.flatnonzero(index)  # the mask's rows, found once for every field
            return type(self)(**{name: v[index] for name, v in zip(names, values, strict=True)})
        return type(self)(**{name: _take(v, rows) for name, v in zip(names, values, strict=True)})

    def take_and_append(self, rows: NDArray[np.integer] | NDArray[np.bool_], born: Self) -> Self:
        """``concat([self.take(rows), born])``, each numpy field written once into its result."""
        names = _field_names(type(self))
        index = np.asarray(rows)
        mode = "raise"
        if index.dtype == np.bool_ and index.shape == (len(self),):
            index, mode = np.flatnonzero(index), "clip"  # rows of the mask: always in range
        k = len(index)
        out = {}
        for name in names:
            v, b = getattr(self, name), getattr(born, name)
            same_kind = type(v) is np.ndarray and type(b) is np.ndarray and v.dtype == b.dtype
            if same_kind and v.shape[1:] == b.shape[1:]:
                o = np.empty((k + len(b), *v.shape[1:]), dtype=v.dtype)
                if mode == "clip":
                    v.take(index, axis=0, out=o[:k], mode="clip")
                else:
                    o[:k] = v[index]
                o[k:] = b
                out[name] = o
            else:
                out[name] = _concat([_take(v, rows), b])
        return type(self)(**out)

    @classmethod
    def concat(cls, states: Sequence[Self]) -> Self:
        """The tracks of ``states`` one after another (all of this class); each field keeps its type."""
        if not states:
            raise ValueError(f"{cls.__name__}.concat needs at least one state")
        return cls(**{name: _concat([getattr(s, name) for s in states]) for name in _field_names(cls)})


_FIELD_NAMES: dict[type, tuple[str, ...]] = {}


def _field_names(cls: type) -> tuple[str, ...]:
    """The dataclass field names of a state class (looked up once per class)."""
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))
    return names


def _is_torch(value: Any) -> bool:
    return type(value).__module__.partition(".")[0] == "torch"


def _take(value: Any, rows: Any) -> Any:
    if _is_torch(value):
        import torch

        index = torch.as_tensor(np.asarray(rows), device=value.device)
        return value[index]
    return np.asarray(value)[rows]


def _concat(values: list[Any]) -> Any:
    if all(type(v) is np.ndarray for v in values):
        return np.concatenate(values)
    if any(_is_torch(v) for v in values):
        if not all(_is_torch(v) for v in values):
            kinds = sorted({type(v).__name__ for v in values})
            raise TypeError(f"cannot concatenate a state field mixing {kinds}; keep one array type per field")
        import torch

        return torch.cat(values)
    return np.concatenate(values)


@runtime_checkable
class Predictor(Protocol):
    """Batched motion model with uncertainty: the core every tracker relies on (module docstring)."""

    def reset(self, spec: SensorSpec) -> None:
        """Bind to a sensor: frame period, dimension and measurement noise."""
        ...

    def start(self, z: NDArray[np.floating]) -> Any:
        """States of new tracks from their first measurements ``z`` (n, D)."""
        ...

    def predict(self, state: Any) -> tuple[Any, Gaussian]:
        """Move every track one frame on; the predicted measurement of each."""
        ...

    def update(self, state: Any, z: NDArray[np.floating], seen: NDArray[np.bool_]) -> Any:
        """Correct the tracks with ``seen`` True by their rows of ``z`` (n, D); the rest coast."""
        ...

    def estimate(self, state: Any) -> Gaussian:
        """Current (posterior) estimate of every track in measurement space, what a tracker reports."""
        ...


class Capability(StrEnum):
    """The optional capabilities a predictor class may declare (module docstring)."""

    NOISE_SCALE = "noise-scale"
    VELOCITY_PRIOR = "velocity-prior"
    MEAN_ONLY_ESTIMATE = "mean-only-estimate"
    FUSED_SURVIVORS_BIRTHS = "fused-survivors-births"
    LINE_ROLLOUT = "line-rollout"
    COAST = "coast"
    CALIBRATION = "calibration"
    RANDOM_STREAM = "random-stream"
    MIXTURE_UPDATE = "mixture-update"
    TRANSLATE = "translate"
    KINEMATIC_MODEL = "kinematic-model"


class Crossings(NamedTuple):
    """What a line roll-out returns for ``k`` tracks (the compiled passes build it too).

    Attributes:
        ok: (k,) bool, whether the roll-out found a crossing of the line.
        mean: (k, 2) the crossing's time on the env's clock and lateral position ``(t̂, ŷ)``
            (NaN where not ``ok``).
        cov: (k, 2, 2) their covariance (NaN where not ``ok``).
    """

    ok: NDArray[np.bool_]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]


class NoiseScale(Predictor, Protocol):
    """``NOISE_SCALE``: the measurement noise the predictor assumes can be scaled."""

    def set_noise_scale(self, scale: float) -> None:
        """Assume ``R = (scale · noise_std)² I`` from the next call on (``scale`` > 0, finite)."""
        ...


class VelocityPrior(Predictor, Protocol):
    """``VELOCITY_PRIOR``: ``start`` also takes a prior on the velocity of new tracks."""

    def start(
        self,
        z: NDArray[np.floating],
        velocity: NDArray[np.floating] | None = None,
        velocity_cov: NDArray[np.floating] | None = None,
    ) -> Any:
        """New tracks at ``z`` (n, D) with velocity prior ``N(velocity (n, D), velocity_cov (n, D, D))``."""
        ...


class MeanOnlyEstimate(Predictor, Protocol):
    """``MEAN_ONLY_ESTIMATE``: the estimate's mean without computing its covariance."""

    def estimate_mean(self, state: Any) -> NDArray[np.floating]:
        """``estimate(state).mean`` (n, D)."""
        ...


class FusedSurvivorsBirths(Predictor, Protocol):
    """``FUSED_SURVIVORS_BIRTHS``: deletions and births in one pass."""

    def survivors_and_births(
        self,
        state: Any,
        keep: NDArray[np.bool_],
        n_keep: int,
        z: NDArray[np.floating],
        velocity: NDArray[np.floating] | None = None,
        velocity_cov: NDArray[np.floating] | None = None,
    ) -> Any:
        """``concat([state.take(keep), start(z)])`` (``n_keep`` = ``keep.sum()``), the new tracks
        started with the velocity prior ``velocity`` (D,), ``velocity_cov`` (D, D) where the
        predictor has one (ignored otherwise)."""
        ...


class LineRollout(Predictor, Protocol):
    """``LINE_ROLLOUT``: the roll-out to a line in one compiled pass, and its covariance mode."""

    #: ``"state"``: ``estimate`` after coasting carries the multi-step covariance;
    #: ``"accumulate"``: it is the one-step prediction, and a roll-out sums those.
    rollout_covariance: Literal["state", "accumulate"]

    def rollout_crossings(
        self, state: Any, line: float, frame: int, dt: float, max_steps: int
    ) -> Crossings | None:
        """The crossings of ``x = line`` of every track of ``state`` (at frame ``frame``) that the
        frame-by-frame roll-out of at most ``max_steps`` frames finds, or ``None`` where this
        pass does not apply (the tracker then rolls frame by frame)."""
        ...


class Coast(Predictor, Protocol):
    """``COAST``: predict and coast in one call."""

    def coast(self, state: Any) -> tuple[Any, Gaussian]:
        """``predict`` then ``update`` with nothing seen; the new state and the prediction."""
        ...


class Calibrated(Predictor, Protocol):
    """``CALIBRATION``: the factor the predicted covariances were calibrated by."""

    #: ``r`` (1: uncalibrated): the predicted covariance is ``r`` times the model's own.
    calibration_scale: float


class MixtureUpdate(Predictor, Protocol):
    """``MIXTURE_UPDATE``: the moment-matched update by a mixture of measurements (PDA)."""

    def update_mixture(
        self,
        state: Any,
        z_mean: NDArray[np.floating],
        z_spread: NDArray[np.floating],
        p_seen: NDArray[np.floating],
    ) -> Any:
        """Correct every track by its measurement mixture: detected with probability ``p_seen``
        (n,) in [0, 1], then by a measurement of mean ``z_mean`` (n, D) and spread ``z_spread``
        (n, D, D); ``p_seen = 0`` coasts exactly and ``p_seen = 1`` with zero spread equals
        ``update``."""
        ...


class Translate(Predictor, Protocol):
    """``TRANSLATE``: move tracks without changing their motion."""

    def translate(self, state: Any, offset: NDArray[np.floating]) -> Any:
        """Every track moved by ``offset`` (n, D) in measurement space: its estimate and its next
        prediction shift by that much, its velocity (and what else it knows of its motion) stays."""
        ...


class RandomStream(Predictor, Protocol):
    """``RANDOM_STREAM``: ``reset`` takes the random stream the predictor draws from."""

    def reset(self, spec: SensorSpec, *, rng: np.random.Generator | None = None) -> None:
        """Bind to ``spec`` and draw every random number from ``rng`` until the next reset."""
        ...


class KinematicModel(Predictor, Protocol):
    """``KINEMATIC_MODEL``: a linear Kalman filter of an ``order``-fold integrator per axis."""

    #: Derivatives of the position per axis in the state: 1 (random walk), 2 (constant
    #: velocity), 3 (constant acceleration).
    order: int

    def kinematic_model(
        self, dim: int, dt: float, q: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(F, Q, H)`` of the model for ``dim`` axes, frame period ``dt`` and white-noise
        intensity ``q``: transition (S, S), process noise (S, S) and measurement (dim, S),
        ``S = order · dim``."""
        ...


#: The protocol of every capability.
PROTOCOLS: dict[Capability, type] = {
    Capability.NOISE_SCALE: NoiseScale,
    Capability.VELOCITY_PRIOR: VelocityPrior,
    Capability.MEAN_ONLY_ESTIMATE: MeanOnlyEstimate,
    Capability.FUSED_SURVIVORS_BIRTHS: FusedSurvivorsBirths,
    Capability.LINE_ROLLOUT: LineRollout,
    Capability.COAST: Coast,
    Capability.CALIBRATION: Calibrated,
    Capability.RANDOM_STREAM: RandomStream,
    Capability.MIXTURE_UPDATE: MixtureUpdate,
    Capability.TRANSLATE: Translate,
    Capability.KINEMATIC_MODEL: KinematicModel,
}


#: The capabilities of predictors, read with [`capability`][predictors.capability]
#: ([`track_envs.infra.declared`][track_envs.infra.declared]).
DECLARATIONS: Declarations[Capability] = Declarations(Capability, PROTOCOLS, core=Predictor)


def declared_capabilities(predictor: object) -> frozenset[Capability]:
    """The capabilities ``predictor``'s class declares (empty when it declares none).

    Raises:
        TypeError: if the class's ``capabilities`` is not a set of [`Capability`][predictors.Capability]
            members.
    """
    return DECLARATIONS.declared(predictor)


@overload
def capability(predictor: object, which: Literal[Capability.NOISE_SCALE]) -> NoiseScale | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.VELOCITY_PRIOR]) -> VelocityPrior | None: ...
@overload
def capability(
    predictor: object, which: Literal[Capability.MEAN_ONLY_ESTIMATE]
) -> MeanOnlyEstimate | None: ...
@overload
def capability(
    predictor: object, which: Literal[Capability.FUSED_SURVIVORS_BIRTHS]
) -> FusedSurvivorsBirths | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.LINE_ROLLOUT]) -> LineRollout | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.COAST]) -> Coast | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.CALIBRATION]) -> Calibrated | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.RANDOM_STREAM]) -> RandomStream | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.MIXTURE_UPDATE]) -> MixtureUpdate | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.TRANSLATE]) -> Translate | None: ...
@overload
def capability(predictor: object, which: Literal[Capability.KINEMATIC_MODEL]) -> KinematicModel | None: ...
def capability(predictor: object, which: Capability) -> Any:
    """``predictor``, typed as the protocol of capability ``which``, when its class declares it;
    else ``None``. The one way a tracker asks for an optional capability (module docstring).

    Raises:
        TypeError: if the class declares ``which`` but lacks a member of its protocol (named), or
            ``which`` is not a [`Capability`][predictors.Capability].
    """
    return DECLARATIONS.get(predictor, which)


def has_capability(predictor: object, which: Capability) -> bool:
    """Whether ``predictor``'s class declares capability ``which`` (checked as
    [`capability`][predictors.capability] does)."""
    return capability(predictor, which) is not None  # type: ignore[call-overload]


def reset_predictor(predictor: Predictor, spec: SensorSpec, rng: np.random.Generator) -> None:
    """``predictor.reset(spec, rng=rng)`` where it declares ``RANDOM_STREAM``, else ``reset(spec)``."""
    streamed = capability(predictor, Capability.RANDOM_STREAM)
    if streamed is not None:
        streamed.reset(spec, rng=rng)
    else:
        predictor.reset(spec)
