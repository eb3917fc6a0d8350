"""The belt LSTMs as Predictors: ``lstm``, ``nll-lstm`` and ``mc-lstm`` (Pollithy et al. 2020).

A track's state carries the recurrent state ``(h1, c1, h2, c2)`` of the network *after* it consumed
the track's last input, the head's output for the next step, and that last input ``z``. So

* ``start(z)`` runs one step from the zero state on ``(z, Δ = 0)``;
* ``predict(state)`` turns the stored head output into ``N(ŷ, Σ)`` — no network call;
* ``update(state, z, seen)`` runs one step per track on ``z`` where seen, and on the track's own
  prediction ``ŷ`` where it coasts (a missed detection), as the paper's tracker does.

The covariance of the predicted measurement depends on the model:

* ``lstm``: ``Σ = s·I`` with ``s`` from the model file (``calibration.cov_scale``, sensor units²;
  the training command line-searches it on validation tracks);
* ``nll-lstm``: ``Σ = r · diag(σ²)`` with ``log σ²`` the network's second output head;
* ``mc-lstm``: ``T`` Monte Carlo passes with variational dropout masks drawn once per track at
  ``start`` (from the generator given to ``reset``) and kept for its life; the predictive mean and
  covariance are eqs. (3)–(4) of the paper, ``ŷ = (1/T) Σ_k ŷ_k`` and
  ``Σ = τ⁻¹ I + (1/T) Σ_k ŷ_k ŷ_kᵀ − ŷ ŷᵀ`` with ``τ = p l² / (2 N λ)``, times ``r``.

``r`` is the calibration factor of the model file (1 when uncalibrated). Inputs are relative to
the sensor region: the offset is the bound spec's ``region_low`` (so a model works on a camera
window placed elsewhere), the scale the one the model was trained with.
Inference runs in numpy ([`predictors.belt_lstm.inference`][predictors.belt_lstm.inference]); torch is not
needed to track. Every network step runs with numpy's BLAS on one thread
([`track_envs.infra.blas_threads.frame_blas`][track_envs.infra.blas_threads.frame_blas]):
its products are too small to gain from more, and a split product stalls when another process is
busy on the other cores.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from predictors.base import BatchState, Capability, Crossings
from predictors.belt_lstm.features import nll_gaussian
from predictors.belt_lstm.inference import FastLSTMWeights, LSTMWeights
from predictors.training.model_file import ModelFile, ModelFileError, load_model, require_shapes
from track_envs.infra.blas_threads import frame_blas
from track_envs.values.types import Gaussian, SensorSpec

FloatArray = NDArray[np.float64]
#: The belt LSTM kinds.
KINDS = ("lstm", "nll-lstm", "mc-lstm")


def shipped_weights(kind: str, particle_kind: str = "cylinder") -> Path:
    """Path (without suffix) of the shipped weights of ``kind`` trained on ``particle_kind``."""
    return Path(str(resources.files("predictors") / "weights" / f"{kind}-{particle_kind}"))


@dataclass(frozen=True)
class LSTMTrackState(BatchState):
    """Per-track state of a belt LSTM (first axis: tracks; mc-lstm adds a sample axis).

    Attributes:
        h1, c1, h2, c2: Recurrent state after the last input, (n, H) or (n, T, H).
        out: Head output for the next step, (n, outputs) or (n, T, outputs), standardised.
        z: The current estimate, (n, D): the last measurement, or the prediction after ``predict``.
        z_cov: Covariance of ``z``, (n, D, D): the sensor's R when seen, the prediction's otherwise.
        z_prev: The last input the network consumed (for the next input's difference), (n, D).
        masks: mc-lstm's dropout masks, (n, T, Σ widths); (n, 0) for the other kinds.
    """

    h1: FloatArray
    c1: FloatArray
    h2: FloatArray
    c2: FloatArray
    out: FloatArray
    z: FloatArray
    z_cov: FloatArray
    z_prev: FloatArray
    masks: FloatArray


class LSTMPredictor:
    """A belt LSTM (``kind`` one of [`KINDS`][predictors.belt_lstm.predictor.KINDS]) as a batched Predictor.

    Args:
        kind: ``"lstm"``, ``"nll-lstm"`` or ``"mc-lstm"``.
        weights: A model file (path with or without suffix) or a loaded
            [`ModelFile`][predictors.training.ModelFile]; ``None`` takes the shipped weights for
            ``particle_kind``.
        particle_kind: Which shipped weights to load when ``weights`` is ``None``.
        samples: Monte Carlo passes ``T`` of mc-lstm (Pollithy et al. 2020 use 250).
        mc_inference: ``"grouped"`` computes each distinct dropout sample once
            ([`predictors.belt_lstm.mc_dropout`][predictors.belt_lstm.mc_dropout], exact and several times
            faster); ``"plain"`` runs all ``T`` masked passes (the reference it is tested against).
        precision: ``"float32"`` (the fast path, equal to torch's float32 network to ~1e-7) or
            ``"float64"`` (the reference path the tests compare with).
    """

    #: The optional capabilities ([`predictors.base`][predictors.base]) every belt LSTM offers.
    capabilities: ClassVar[frozenset[Capability]] = frozenset(
        {
            Capability.RANDOM_STREAM,
            Capability.CALIBRATION,
            Capability.COAST,
            Capability.LINE_ROLLOUT,
            Capability.FUSED_SURVIVORS_BIRTHS,
            Capability.TRANSLATE,
        }
    )
    #: A coasting track's estimate is the one-step prediction from its fed-back input, not a
    #: multi-step covariance: a tracker rolling it forward without measurements sums the
    #: one-step covariances instead.
    rollout_covariance: ClassVar[Literal["state", "accumulate"]] = "accumulate"

    def __init__(
        self,
        kind: str,
        weights: str | os.PathLike[str] | ModelFile | None = None,
        *,
        particle_kind: str = "cylinder",
        samples: int = 250,
        mc_inference: str = "grouped",
        precision: str = "float32",
    ):
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        if not (isinstance(samples, int) and samples >= 1):
            raise ValueError(f"samples must be an integer >= 1, got {samples!r}")
        if mc_inference not in ("grouped", "plain"):
            raise ValueError(f"mc_inference must be 'grouped' or 'plain', got {mc_inference!r}")
        self.mc_inference = mc_inference
        if precision not in ("float32", "float64"):
            raise ValueError(f"precision must be 'float32' or 'float64', got {precision!r}")
        self.precision = precision
        if weights is None:
            path = shipped_weights(kind, particle_kind)
            if not path.with_name(path.name + ".json").is_file():
                raise ModelFileError(
                    f"no shipped {kind!r} weights for particle_kind={particle_kind!r} ({path}.json); "
                    f"train them with `track train {kind} --out FILE` and pass weights=FILE"
                )
            weights = path
        model = weights if isinstance(weights, ModelFile) else load_model(weights, kind=kind, dim=2)
        if model.kind != kind:
            raise ModelFileError(f"{model.path}: holds a {model.kind!r} model, not {kind!r}")
        self.kind, self.model, self.samples = kind, model, samples
        self._load(model)
        self._spec: SensorSpec | None = None
        self._rng = np.random.default_rng(0)

    def _load(self, model: ModelFile) -> None:
        from predictors.belt_lstm.features import Features

        arch = model.architecture
        h1, h2 = (int(h) for h in arch["hidden"])
        d = model.dim
        outputs = int(arch["head_outputs"]) * d
        require_shapes(
            model,
            {
                "cell1.weight_ih": (4 * h1, 2 * d),
                "cell1.weight_hh": (4 * h1, h1),
                "cell2.weight_ih": (4 * h2, h1),
                "cell2.weight_hh": (4 * h2, h2),
                "head.weight": (outputs, h2),
                "head.bias": (outputs,),
            },
        )
        if "normalisation" not in model.meta:
            raise ModelFileError(f"{model.path}: the sidecar lacks 'normalisation'")
        reference = LSTMWeights.from_tensors(model.tensors)
        self._rollout_weights = tuple(
            np.ascontiguousarray(a)
            for a in (
                reference.layer1.stacked(),
                reference.layer1.b,
                reference.layer2.stacked(),
                reference.layer2.b,
                reference.head_w,
                reference.head_b,
            )
        )
        self.net: Any = reference if self.precision == "float64" else FastLSTMWeights.from_weights(reference)
        self.features = Features.from_dict(model.meta["normalisation"])
        calibration = model.meta.get("calibration", {})
        self.calibration_scale = float(calibration.get("scale", 1.0))
        self.cov_scale = float(calibration.get("cov_scale", 1.0))
        self.dropout = float(arch.get("dropout", 0.0))
        tau = model.meta.get("mc", {}).get("tau")
        self.tau = float(tau) if tau is not None else np.inf
        self._widths = (2 * d, h1, h1, h2, h2)
        from predictors.belt_lstm.mc_dropout import GroupedMC

        self._grouped = GroupedMC(self.net, self._widths, 1.0 - self.dropout)

    def __repr__(self) -> str:
        return f"LSTMPredictor({self.kind!r}, weights={str(self.model.path)!r})"

    # -- protocol --------------------------------------------------------------------------------
    def reset(self, spec: SensorSpec, *, rng: np.random.Generator | None = None) -> None:
        """Bind to ``spec`` (region offset, R) and take the random stream for mc-lstm's masks."""
        if spec.dim != self.model.dim:
            raise ValueError(
                f"{self!r} predicts {self.model.dim}-D measurements, the sensor has dim {spec.dim}"
            )
        self._spec = spec
        self._features = dataclasses.replace(self.features, low=np.asarray(spec.region_low, dtype=np.float64))
        self._R = np.asarray(spec.measurement_cov, dtype=np.float64)
        self._rng = rng if rng is not None else np.random.default_rng(0)

    def _need_spec(self) -> SensorSpec:
        if self._spec is None:
            raise RuntimeError(f"{self!r}: call reset(spec) before start/predict/update")
        return self._spec

    def _check_z(self, z: NDArray[np.floating], n: int | None = None) -> FloatArray:
        spec = self._need_spec()
        a = np.asarray(z, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != spec.dim or (n is not None and a.shape[0] != n):
            want = f"({n if n is not None else 'n'}, {spec.dim})"
            raise ValueError(f"measurements must have shape {want}, got {a.shape}")
        if np.isfinite(a).all():
            return a
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            raise ValueError(f"measurement rows {np.flatnonzero(bad)[:10].tolist()} hold NaN or inf")
        return a

    def start(self, z: NDArray[np.floating]) -> Any:
        """New tracks from their first measurements ``z`` (n, D)."""
        z = self._check_z(z)
        n = len(z)
        masks = self._draw_masks(n)
        x = self._features.inputs(z, None)
        R = np.empty((n, *self._R.shape))
        R[...] = self._R
        if self._is_grouped:
            with frame_blas():
                started = self._grouped.start(x, masks)
            return dataclasses.replace(started, z=z, z_cov=R, z_prev=z.copy())
        out, (h1, c1, h2, c2) = self._step(x, self._zero(n), masks)
        return LSTMTrackState(h1, c1, h2, c2, out, z, R, z.copy(), masks)

    @property
    def _is_grouped(self) -> bool:
        return self.kind == "mc-lstm" and self.mc_inference == "grouped"

    def predict(self, state: Any) -> tuple[Any, Gaussian]:
        """The predicted next measurement of every track (no network call).

        The returned state's estimate is the prediction, so a track that then coasts reports it.
        """
        self._need_spec()
        prediction = self._prediction(state)
        if type(state) is LSTMTrackState:  # (dataclasses.replace, without its field lookups)
            s = state
            moved = LSTMTrackState(
                s.h1, s.c1, s.h2, s.c2, s.out, prediction.mean, prediction.cov, s.z_prev, s.masks
            )
        else:
            moved = dataclasses.replace(state, z=prediction.mean, z_cov=prediction.cov)
        return moved, prediction

    def update(self, state: Any, z: NDArray[np.floating], seen: NDArray[np.bool_]) -> Any:
        """Feed ``z`` to the tracks with ``seen``; the others are fed their prediction.

        Rows of ``z`` that are not seen are ignored (they may hold NaN).
        """
        n = len(state)
        seen = np.asarray(seen, dtype=bool)
        if seen.shape != (n,):
            raise ValueError(f"seen must have shape ({n},), got {seen.shape}")
        z = np.asarray(z, dtype=np.float64)
        if z.shape != state.z.shape:
            raise ValueError(f"measurements must have shape {state.z.shape}, got {z.shape}")
        self._check_z(z[seen])
        z_in = np.where(seen[:, None], z, state.z)
        z_cov = np.where(seen[:, None, None], self._R, state.z_cov)
        x = self._features.inputs(z_in, state.z_prev)
        if self._is_grouped:
            with frame_blas():
                stepped = self._grouped.step(x, state)
            return dataclasses.replace(stepped, z=z_in, z_cov=z_cov, z_prev=z_in.copy())
        masks = state.masks if self.kind == "mc-lstm" else None
        out, (h1, c1, h2, c2) = self._step(x, (state.h1, state.c1, state.h2, state.c2), masks)
        return LSTMTrackState(h1, c1, h2, c2, out, z_in, z_cov, z_in.copy(), state.masks)

    def translate(self, state: Any, offset: NDArray[np.floating]) -> Any:
        """Every track moved by ``offset`` (n, D): its estimate ``z`` and its last input ``z_prev``
        shift together, so the next prediction (``z_prev`` plus the network's displacement) moves
        by ``offset`` and the next input's difference is unchanged; the recurrent state stays.

        Raises:
            ValueError: if ``offset`` is not a finite (n, D) array.
        """
        off = np.asarray(offset, dtype=np.float64)
        if off.shape != state.z.shape or not np.all(np.isfinite(off)):
            raise ValueError(f"offset must be finite with shape {state.z.shape}, got {off.shape}")
        return dataclasses.replace(state, z=state.z + off, z_prev=state.z_prev + off)

    def coast(self, state: Any) -> tuple[Any, Gaussian]:
        """[`predict`][predictors.belt_lstm.predictor.LSTMPredictor.predict] then
        [`update`][predictors.belt_lstm.predictor.LSTMPredictor.update] with nothing seen, in one pass: every
        track is fed its own prediction. Returns the new state and the prediction (the roll-out step of
        [`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings]; the same numbers as
        the two calls, without their argument checks)."""
        self._need_spec()
        prediction = self._prediction(state)
        z_in, z_cov = prediction.mean, prediction.cov
        x = self._features.inputs(z_in, state.z_prev)
        if self._is_grouped:
            with frame_blas():
                stepped = self._grouped.step(x, state)
            return dataclasses.replace(stepped, z=z_in, z_cov=z_cov, z_prev=z_in.copy()), prediction
        masks = state.masks if self.kind == "mc-lstm" else None
        out, (h1, c1, h2, c2) = self._step(x, (state.h1, state.c1, state.h2, state.c2), masks)
        return LSTMTrackState(h1, c1, h2, c2, out, z_in, z_cov, z_in.copy(), state.masks), prediction

    def rollout_crossings(
        self, state: Any, line: float, frame: int, dt: float, max_steps: int
    ) -> Crossings | None:
        """The crossings of ``x = line`` that
        [`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings] finds by rolling
        ``state`` forward with [`coast`][predictors.belt_lstm.predictor.LSTMPredictor.coast], in one compiled
        pass over the tracks
        ([`predictors.belt_lstm._kernels.lstm_crossings_kernel`][predictors.belt_lstm._kernels.lstm_crossings_kernel],
        float64); ``None`` where that pass does not apply (mc-lstm, other than 2-D measurements)."""
        if self.kind == "mc-lstm" or self.model.dim != 2 or type(state) is not LSTMTrackState:
            return None
        from predictors.belt_lstm._kernels import lstm_crossings_kernel

        kernel: Any = lstm_crossings_kernel
        self._need_spec()
        f = self._features

        def c64(a: Any) -> FloatArray:
            return np.ascontiguousarray(a, dtype=np.float64)

        return kernel(
            c64(state.out),
            c64(state.h1),
            c64(state.c1),
            c64(state.h2),
            c64(state.c2),
            c64(state.z[:, :2]),
            c64(state.z_prev[:, :2]),
            c64(state.z_cov[:, :2, :2]),
            *self._rollout_weights,
            *(c64(v) for v in (f.low, f.size, f.in_mean, f.in_std, f.out_mean, f.out_std)),
            self.kind == "nll-lstm",
            float(self.cov_scale),
            float(self.calibration_scale),
            float(line),
            float(frame),
            float(dt),
            int(max_steps),
        )

    def survivors_and_births(
        self,
        state: Any,
        keep: NDArray[np.bool_],
        n_keep: int,
        z: NDArray[np.floating],
        velocity: NDArray[np.floating] | None = None,
        velocity_cov: NDArray[np.floating] | None = None,
    ) -> Any:
        """``concat([state.take(keep), start(z)])``, the survivors' fields written once
        ([`take_and_append`][predictors.BatchState.take_and_append]). A belt LSTM takes no velocity
        prior: ``velocity`` and ``velocity_cov`` are ignored."""
        del velocity, velocity_cov
        if not len(z):
            return state.take(keep)
        born = self.start(z)
        if n_keep == 0:
            return born
        if type(state) is LSTMTrackState:
            return state.take_and_append(keep, born)
        return type(born).concat([state.take(keep) if n_keep < len(keep) else state, born])

    def estimate(self, state: Any) -> Gaussian:
        """Each track's last measurement, or its prediction once predicted (and while it coasts)."""
        return Gaussian(state.z.copy(), state.z_cov.copy())

    # -- internals -------------------------------------------------------------------------------
    def _zero(self, n: int) -> tuple[FloatArray, ...]:
        rows = n * self.samples if self.kind == "mc-lstm" else n
        return self.net.zero_state(rows)

    def _draw_masks(self, n: int) -> FloatArray:
        if self.kind != "mc-lstm":
            return np.zeros((n, 0))
        keep = 1.0 - self.dropout
        width = sum(self._widths)
        return (self._rng.random((n, self.samples, width)) < keep) / keep

    def _step(
        self, x: FloatArray, state: tuple[FloatArray, ...], masks: FloatArray | None
    ) -> tuple[FloatArray, tuple[FloatArray, ...]]:
        """One network step; mc-lstm runs ``T`` masked rows per track. Its products run on
        [`frame_blas`][track_envs.infra.blas_threads.frame_blas]'s BLAS threads (one by default)."""
        if self.kind != "mc-lstm" or masks is None:
            with frame_blas():
                out, new = self.net.step(x, state)
            return out, new
        n, T = masks.shape[0], self.samples
        flat = masks.reshape(n * T, -1)
        cuts = np.cumsum(self._widths)[:-1]
        parts = tuple(np.split(flat, cuts, axis=1))
        xs = np.repeat(x, T, axis=0)
        flat_state = tuple(s.reshape(n * T, -1) for s in state)
        with frame_blas():
            out, new = self.net.step(xs, flat_state, parts)
        return out.reshape(n, T, -1), tuple(s.reshape(n, T, -1) for s in new)

    def _prediction(self, state: Any) -> Gaussian:
        f = self._features
        d = self.model.dim
        n = len(state)
        scale = f.variance_scale()  # standardised output variance → sensor units², per axis
        if self.kind == "mc-lstm":
            if self._is_grouped:
                mean_std, cov_std = state.mean[:, :d], state.cov[:, :d, :d]
            else:
                out = state.out[..., :d]  # (n, T, D) standardised
                mean_std = out.mean(axis=1)
                centred = out - mean_std[:, None, :]
                cov_std = np.einsum("ntd,nte->nde", centred, centred) / out.shape[1]
            cov_std = cov_std + np.eye(d) / self.tau
            mean = f.position(state.z_prev, mean_std)
            sd = np.sqrt(scale)
            cov = cov_std * sd[:, None] * sd[None, :]
        elif self.kind == "nll-lstm":  # one compiled pass, the operations of the lstm branch below
            mean, cov = np.empty((n, d)), np.empty((n, d, d))
            z_prev = np.ascontiguousarray(state.z_prev, dtype=np.float64)
            var_std = np.exp(state.out[:, d:])
            nll_gaussian(
                z_prev, state.out, var_std, f.size, f.out_mean, f.out_std, scale,
                float(self.calibration_scale), mean, cov,
            )  # fmt: skip
            return Gaussian(mean, cov)
        else:
            mean = f.position(state.z_prev, state.out[:, :d])
            cov = np.broadcast_to(self.cov_scale * np.eye(d), (n, d, d)).copy()
        return Gaussian(mean, self.calibration_scale * cov)
