"""The Predictor protocol and the batched state value every predictor keeps per track.

A predictor is a motion model with uncertainty, batched over ``n`` tracks. The tracker owns the
state (an immutable value) and calls, each frame,

1. ``predict(state) -> (state, Gaussian)``: move every track one frame on and return the predicted
   measurement ``N(mean (n, D), cov (n, D, D))`` used for gating and association;
2. ``update(state, z, seen) -> state``: correct the tracks with ``seen[i]`` True by ``z[i]``; the
   others coast (their predicted state is kept);
3. ``estimate(state) -> Gaussian``: the current estimate, which the tracker reports;
4. ``start(z) -> state`` for new tracks, ``state.take(rows)`` for survivors and
   ``type(state).concat([a, b])`` to append births.

``reset(spec)`` binds the predictor to an environment's :class:`~track_envs.types.SensorSpec`
(frame period, measurement noise, dimension) before the first ``start``.

Two optional capabilities, which a tracker checks for instead of assuming them:

* :class:`VelocityPriorPredictor` — ``start(z, velocity=..., velocity_cov=...)`` accepts a prior
  on the velocity of new tracks (the Kalman predictors); test with :func:`accepts_velocity_prior`.
* :class:`StochasticPredictor` — ``reset(spec, rng=...)`` takes the random stream the predictor
  draws from (e.g. MC-dropout masks), derived by the tracker from its seed, so the same seed gives
  the same masks and the same report; :func:`reset_predictor` passes it where accepted.

The same five calls fit a Kalman filter (mean and covariance per track), an LSTM (hidden state
per track, carried and never re-run over a window), an MC-dropout LSTM (dropout masks fixed per
track inside the state), an NLL-LSTM (predicted variance) and a per-keypoint particle predictor:
each keeps whatever it needs per track in the fields of its :class:`BatchState`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from track_envs.types import Gaussian, SensorSpec


@dataclass(frozen=True)
class BatchState:
    """Base of per-track predictor states: every field is an array whose first axis is the track.

    Subclasses only declare fields; :meth:`take`, :meth:`concat` and ``len`` work on all of them.
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
    """Batched motion model with uncertainty (see the module docstring for the call order)."""

    def reset(self, spec: SensorSpec) -> None:
        """Bind to a sensor: frame period, dimension and measurement noise."""
        ...

    def start(self, z: NDArray[np.floating]) -> Any:
        """States of new tracks from their first measurements ``z`` (n, D).

        Kinematic predictors may also accept ``velocity=`` (n, D) and ``velocity_cov=`` (n, D, D)
        keywords, a tracker's prior on the velocity of new tracks.
        """
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


@runtime_checkable
class VelocityPriorPredictor(Predictor, Protocol):
    """A predictor whose ``start`` also takes a prior on the velocity of new tracks."""

    def start(
        self,
        z: NDArray[np.floating],
        *,
        velocity: NDArray[np.floating] | None = None,
        velocity_cov: NDArray[np.floating] | None = None,
    ) -> Any:
        """New tracks at ``z`` (n, D) with velocity prior ``N(velocity (n, D), velocity_cov (n, D, D))``."""
        ...


def accepts_velocity_prior(predictor: Any) -> bool:
    """Whether ``predictor.start`` takes ``velocity=`` and ``velocity_cov=`` keywords."""
    return _accepts(predictor.start, "velocity", "velocity_cov")


def reset_predictor(predictor: Any, spec: SensorSpec, rng: np.random.Generator) -> None:
    """``predictor.reset(spec, rng=rng)`` where it takes a random stream, else ``reset(spec)``."""
    if _accepts(predictor.reset, "rng"):
        predictor.reset(spec, rng=rng)
    else:
        predictor.reset(spec)


def _accepts(method: Any, *names: str) -> bool:
    import inspect

    try:
        params = inspect.signature(method).parameters
    except (TypeError, ValueError):
        return False
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return True
    return all(n in params for n in names)
