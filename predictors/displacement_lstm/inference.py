"""The displacement LSTM in numpy (no torch): one step batched over targets, from a model file.

One step of the LSTM layer (torch's gate order ``i, f, g, o``;
[`LSTMCellWeights`][predictors.LSTMCellWeights]) and the head, for ``T`` targets at once with
state ``h, c`` (T, H):

    a = x W_ihᵀ + h W_hhᵀ + b,   c' = σ(a_f) c + σ(a_i) tanh(a_g),   h' = σ(a_o) tanh(c'),
    (r̂, ŝ) = (r̄, s̄) ⊙ (h' W_headᵀ + b_head),   x = (r / r̄, s / s̄).

It equals [`DisplacementLSTMNet`][predictors.displacement_lstm.network.DisplacementLSTMNet] to 1e-6 (tested).
The scales ``r̄, s̄`` ([`DisplacementFeatures`][predictors.displacement_lstm.inference.DisplacementFeatures])
come from the model file's ``normalisation``; ``speed_scale`` may be overridden to run a model in another unit
system.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from predictors.lstm_cell import LSTMCellWeights
from predictors.training.model_file import ModelFile, ModelFileError, load_model, require_shapes

FloatArray = NDArray[np.float64]
#: The model kind of the displacement LSTM (also
#: [`predictors.displacement_lstm.network.KIND`][predictors.displacement_lstm.network.KIND]).
KIND = "displacement-lstm"
#: Name of the shipped weights, trained on the noiseless sine of Jung et al. (2019), eq. (5).
SHIPPED = "displacement-lstm-sine"


def shipped_displacement_weights(name: str = SHIPPED) -> Path:
    """Path (without suffix) of shipped displacement weights (package data)."""
    return Path(str(resources.files("predictors") / "weights" / name))


def tensor_shapes(hidden: int) -> dict[str, tuple[int, ...]]:
    """The state-dict shapes of a displacement network of ``hidden`` units."""
    return {
        "lstm.weight_ih_l0": (4 * hidden, 2),
        "lstm.weight_hh_l0": (4 * hidden, hidden),
        "lstm.bias_ih_l0": (4 * hidden,),
        "lstm.bias_hh_l0": (4 * hidden,),
        "head.weight": (2, hidden),
        "head.bias": (2,),
    }


@dataclass(frozen=True)
class DisplacementFeatures:
    """Scales of the network's inputs and outputs ``(r / r̄, s / s̄)``.

    Attributes:
        rotation_scale: ``r̄``, the RMS rotation of the training data (rad, floored at 1e-3).
        speed_scale: ``s̄``, the mean speed of the training data (its units per frame).
        step: The step ``Δ`` of the training data where it has one (the sine: 0.2), else ``None``.
    """

    rotation_scale: float
    speed_scale: float
    step: float | None = None

    @classmethod
    def fit(cls, rotation: ArrayLike, speed: ArrayLike, step: float | None = None) -> DisplacementFeatures:
        """Scales of the rotations and speeds of the training steps (flat arrays)."""
        r = np.asarray(rotation, dtype=np.float64)
        s = np.asarray(speed, dtype=np.float64)
        if not (len(s) and s.mean() > 0):
            raise ValueError("the training tracks do not move (mean speed 0); nothing to learn")
        return cls(max(float(np.sqrt(np.mean(r**2))), 1e-3), float(s.mean()), step)

    def to_dict(self) -> dict[str, Any]:
        """JSON form for a model sidecar."""
        return {"rotation_scale": self.rotation_scale, "speed_scale": self.speed_scale, "step": self.step}

    @classmethod
    def from_dict(cls, d: Any, where: Any = "<model>") -> DisplacementFeatures:
        """Inverse of [`to_dict`][predictors.displacement_lstm.inference.DisplacementFeatures.to_dict] (a
        missing or non-positive scale raises [`ModelFileError`][predictors.training.ModelFileError])."""
        try:
            rs, ss = float(d["rotation_scale"]), float(d["speed_scale"])
        except (KeyError, TypeError, ValueError):
            raise ModelFileError(
                f"{where}: normalisation must hold rotation_scale and speed_scale, got {d!r}"
            ) from None
        if not (np.isfinite(rs) and rs > 0 and np.isfinite(ss) and ss > 0):
            raise ModelFileError(f"{where}: normalisation scales must be > 0, got {d!r}")
        step = d.get("step")
        return cls(rs, ss, None if step is None else float(step))


@dataclass(frozen=True)
class DisplacementLSTM:
    """The displacement network's weights, ready for batched numpy steps.

    Attributes:
        layer: The LSTM layer (float64).
        head_w: (H, 2) head weight (transposed).
        head_b: (2,) head bias.
        features: The input / output scales.
        path: The sidecar it was loaded from, if any.
    """

    layer: LSTMCellWeights
    head_w: FloatArray
    head_b: FloatArray
    features: DisplacementFeatures
    path: Path | None = None

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return self.layer.hidden

    @classmethod
    def from_model_file(cls, model: ModelFile) -> DisplacementLSTM:
        """From a loaded model file of kind ``displacement-lstm`` (else
        [`ModelFileError`][predictors.training.ModelFileError])."""
        where = model.path or f"<{model.kind} model>"
        if model.kind != KIND:
            raise ModelFileError(f"{where} holds a {model.kind!r} model; expected {KIND!r}")
        hidden = model.architecture.get("hidden")
        if not (isinstance(hidden, int) and hidden >= 1):
            raise ModelFileError(f"{where}: architecture.hidden must be an integer >= 1, got {hidden!r}")
        require_shapes(model, tensor_shapes(hidden))
        t = {k: np.asarray(v, dtype=np.float64) for k, v in model.tensors.items()}
        layer = LSTMCellWeights.from_tensors(t, "lstm.", "_l0")
        features = DisplacementFeatures.from_dict(model.meta.get("normalisation"), where)
        return cls(layer, t["head.weight"].T.copy(), t["head.bias"].copy(), features, model.path)

    @classmethod
    def load(cls, weights: str | os.PathLike[str] | ModelFile | None = None) -> DisplacementLSTM:
        """From a model file path (suffix optional), a loaded [`ModelFile`][predictors.training.ModelFile], or
        ``None`` for the shipped sine-trained weights.

        Raises:
            ModelFileError: a missing or corrupt file, another kind or dimension, wrong shapes.
        """
        if isinstance(weights, ModelFile):
            return cls.from_model_file(weights)
        if weights is not None and not isinstance(weights, str | os.PathLike):
            raise ValueError(
                f"weights must be a model file path, a ModelFile or None (the shipped {SHIPPED!r}), "
                f"got {weights!r}"
            )
        path = shipped_displacement_weights() if weights is None else weights
        return cls.from_model_file(load_model(path, kind=KIND, dim=2))

    def zero_state(self, n: int) -> tuple[FloatArray, FloatArray]:
        """Zero ``(h, c)`` (n, H) for ``n`` new targets."""
        return np.zeros((n, self.hidden)), np.zeros((n, self.hidden))

    def step_scaled(
        self, x: FloatArray, h: FloatArray, c: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """One step in network units: input ``x`` (n, 2) → output (n, 2), new ``h, c``."""
        h_new, c_new = self.layer.step(x, h, c)
        return h_new @ self.head_w + self.head_b, h_new, c_new

    def step(
        self,
        rotation: ArrayLike,
        speed: ArrayLike,
        h: FloatArray,
        c: FloatArray,
        *,
        speed_scale: float | None = None,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(r̂_t, ŝ_t, h', c')`` from ``(r_{t−1}, s_{t−1})`` (n,) each and the state (n, H).

        ``speed_scale``: ``s̄`` in the caller's units (default: the model file's).
        """
        f = self.features
        ss = f.speed_scale if speed_scale is None else float(speed_scale)
        x = np.stack(
            [np.asarray(rotation, dtype=np.float64) / f.rotation_scale, np.asarray(speed, np.float64) / ss],
            axis=-1,
        )
        out, h_new, c_new = self.step_scaled(x, h, c)
        return out[:, 0] * f.rotation_scale, out[:, 1] * ss, h_new, c_new

    def frame(
        self,
        newest: FloatArray,
        previous: FloatArray,
        state: tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]],
        *,
        speed_scale: float | None = None,
    ) -> FloatArray:
        """One filter frame for every target in one compiled pass: the displacements (T, 2).

        From the newest two estimates ``newest, previous`` (T, 2) (NaN where unknown): the
        ``(r, s)`` of the last step, one LSTM step, and ``ŝ (cos(c + r̂), sin(c + r̂))`` applied to
        the heading ``c``
        ([`predictors.displacement_lstm._kernels.displacement_frame`][predictors.displacement_lstm._kernels.displacement_frame]).
        ``state = (h, c, heading, has_heading)`` ((T, H), (T, H), (T,), (T,)) is updated in place; a target
        whose ``previous`` is NaN (re)starts from the zero state.
        """
        from predictors.displacement_lstm._kernels import displacement_frame

        h, c, heading, has_heading = state
        return displacement_frame(
            np.ascontiguousarray(newest, dtype=np.float64),
            np.ascontiguousarray(previous, dtype=np.float64),
            h,
            c,
            heading,
            has_heading,
            self.layer.w_ih,
            self.layer.w_hh,
            self.layer.b,
            self.head_w,
            self.head_b,
            self.features.rotation_scale,
            self.features.speed_scale if speed_scale is None else float(speed_scale),
        )
