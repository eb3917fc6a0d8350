"""Extending track-envs with a learned predictor: a tiny LSTM, trained, saved, loaded and tracked with.

One module and a ``register_predictor`` call, end to end:

1. **data** — true tracks of PiecewiseTarget-v0
([`predictors.training.data.tracks_from_env`][predictors.training.tracks_from_env]),
   seen through the env's sensor noise, split by track ([`split_tracks`][predictors.training.split_tracks]);
2. **network** — a torch LSTM of a few units that reads a track's last displacement and predicts
   the next (`build_network`);
3. **training** — the project's loop ([`predictors.training.loop.fit`][predictors.training.fit]: seeded, CPU,
the best
   validation epoch kept), a few seconds;
4. **model file** — ``NAME.safetensors`` + ``NAME.json`` ([`save_model`][predictors.training.save_model])
   with the input scale and the learned covariance in the sidecar;
5. **inference** — the file loaded back and run by the one inference LSTM,
   [`predictors.lstm_cell.LSTMCellWeights`][predictors.LSTMCellWeights] (numpy; torch is not imported to
   track);
6. **predictor** — `LearnedStepPredictor`, the Predictor protocol over a batch of tracks with
   the LSTM state per track, registered and run in gnn on an episode it was not trained on.

torch is imported only by `build_network` and `train`. Run it::

    python examples/extend_learned_predictor.py --out models/      # trains, saves, tracks
    python examples/extend_learned_predictor.py --model models/learned-step   # tracks only
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors import BatchState, LSTMCellWeights, Predictor, register_predictor
from predictors.training import ModelFile, load_model, require_shapes
from track_envs import Gaussian, SensorSpec

#: The registered predictor name, and the stem of its model file.
NAME = "learned-step"
#: The model file's kind (a loader for one kind refuses another).
KIND = "example-step-lstm"
#: The env the data come from and the tracker runs on.
ENV_ID = "PiecewiseTarget-v0"
FloatArray = NDArray[np.float64]


# -- data -----------------------------------------------------------------------------------------
def measured_tracks(episodes: int, steps: int, seed: int) -> Any:
    """True tracks of ``episodes`` episodes of `ENV_ID` (``steps`` frames each) plus the
    sensor's noise ``N(0, σ_n² I)`` (a seeded generator), split 70/15/15 by track; a
    [`TrackSplit`][predictors.training.TrackSplit]."""
    import gymnasium as gym

    from predictors.training import split_tracks, tracks_from_env

    noise_std = float(gym.make(ENV_ID).unwrapped.sensor_spec.noise_std)  # type: ignore[attr-defined]
    truth = tracks_from_env(ENV_ID, episodes=episodes, steps=steps, seed=seed)
    rng = np.random.default_rng(seed)
    measured = [t + rng.normal(0.0, noise_std, t.shape) for t in truth.tracks]
    return split_tracks(truth.with_tracks(measured, noise_std=noise_std), seed=seed, min_length=10)


def sequences(tracks: Sequence[FloatArray], scale: FloatArray) -> tuple[FloatArray, ...]:
    """Inputs, targets (B, T − 1, D) and mask (B, T − 1) of tracks ``z_0 … z_T``: the input at
    step ``t`` is ``(z_t − z_{t−1}) / scale`` (0 at ``t = 0``), the target ``(z_{t+1} − z_t) / scale``."""
    from predictors.training import pad_tracks

    steps = [np.diff(z, axis=0) / scale for z in tracks]
    inputs, mask = pad_tracks([np.concatenate([np.zeros_like(d[:1]), d[:-1]]) for d in steps])
    targets, _ = pad_tracks(steps)
    return inputs, targets, mask.astype(np.float64)


# -- network (torch; training only) --------------------------------------------------------------
def build_network(hidden: int) -> Any:
    """The torch network: ``nn.LSTM(D → hidden)`` and a linear head ``hidden → D`` (D = 2), with the
    two methods [`trained_model_file`][predictors.training.trained_model_file] reads."""
    from torch import nn

    class StepLSTM(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.lstm = nn.LSTM(2, hidden, batch_first=True)
            self.head = nn.Linear(hidden, 2)

        def forward(self, x: Any) -> Any:
            return self.head(self.lstm(x)[0])

        def numpy_weights(self) -> dict[str, NDArray[np.float32]]:
            return {k: v.detach().cpu().numpy() for k, v in self.state_dict().items()}

        def architecture(self) -> dict[str, Any]:
            return {"hidden": hidden}

    return StepLSTM()


def _mse(model: Any, batch: Sequence[Any], generator: Any) -> Any:
    """Mean squared error of the scaled next displacement over the valid steps."""
    x, y, mask = batch
    return (((model(x) - y) ** 2).sum(-1) * mask).sum() / mask.sum()


def train(
    out: str | os.PathLike[str],
    *,
    hidden: int = 12,
    epochs: int = 150,
    episodes: int = 24,
    steps: int = 60,
    seed: int = 0,
) -> Path:
    """Train the network on `ENV_ID`'s tracks and save it as ``out/NAME``; the model's path.

    The learned covariance is the residual variance per axis of the one-step prediction
    ``ẑ_{t+1} = z_t + Δ̂`` on the validation tracks, run through the numpy inference that tracks.
    """
    import torch

    from predictors.training import TrainConfig, fit, save_model, seeded_init, trained_model_file

    config = TrainConfig(epochs=epochs, lr=0.02, decay_every=max(epochs // 3, 1), seed=seed)
    if not 1 <= hidden <= 64:
        raise ValueError(f"hidden must be in 1..64 units, got {hidden!r}")
    split = measured_tracks(episodes, steps, seed)
    scale = np.concatenate([np.diff(z, axis=0) for z in split.train.tracks]).std(axis=0)

    def tensors(tracks: Sequence[FloatArray]) -> list[torch.Tensor]:
        return [torch.as_tensor(a, dtype=torch.float32) for a in sequences(tracks, scale)]

    net = seeded_init(lambda: build_network(hidden), seed)
    history = fit(
        net, _mse, tensors(split.train.tracks), tensors(split.validation.tracks), config, progress=False
    )
    model = trained_model_file(net, kind=KIND, dim=2, normalisation={"scale": scale.tolist()})
    network = StepNetwork.from_model(model)
    residual_var = network.residual_variance(split.validation.tracks)
    model = dataclasses.replace(
        model,
        meta={
            **model.meta,
            "calibration": {"residual_var": residual_var},
            "data": {**split.train.description, **split.summary()},
            "training": {**history.to_dict(), "config": dataclasses.asdict(config)},
            "metrics": {"test_residual_var": network.residual_variance(split.test.tracks)},
        },
    )
    _, sidecar = save_model(Path(out) / NAME, model)
    print(
        f"trained {KIND} ({hidden} units, {history.best_epoch + 1}/{epochs} epochs, "
        f"{history.wall_time_s:.1f} s): validation loss {min(history.validation_loss):.3f}, "
        f"residual std {np.sqrt(residual_var):.3f} → {sidecar}"
    )
    return Path(out) / NAME


# -- inference (numpy) ---------------------------------------------------------------------------
@dataclass(frozen=True)
class StepNetwork:
    """The network of a model file in numpy: one [`LSTMCellWeights`][predictors.LSTMCellWeights]
    layer and the head ``Δ̂ = scale ⊙ (h W_headᵀ + b_head)``.

    Attributes:
        cell: The LSTM layer (float64).
        head_w: ``W_headᵀ`` (H, D).
        head_b: (D,).
        scale: The displacement scale of inputs and outputs (D,).
    """

    cell: LSTMCellWeights
    head_w: FloatArray
    head_b: FloatArray
    scale: FloatArray

    @classmethod
    def from_model(cls, model: ModelFile) -> StepNetwork:
        """From a model file, its tensors checked against its architecture."""
        hidden, d = int(model.architecture["hidden"]), model.dim
        require_shapes(
            model,
            {
                "lstm.weight_ih_l0": (4 * hidden, d),
                "lstm.weight_hh_l0": (4 * hidden, hidden),
                "head.weight": (d, hidden),
            },
        )
        return cls(
            LSTMCellWeights.from_tensors(model.tensors, "lstm.", "_l0"),
            np.asarray(model.tensors["head.weight"], dtype=np.float64).T.copy(),
            np.asarray(model.tensors["head.bias"], dtype=np.float64),
            np.asarray(model.meta["normalisation"]["scale"], dtype=np.float64),
        )

    def step(self, displacement: FloatArray, h: FloatArray, c: FloatArray) -> tuple[FloatArray, ...]:
        """The predicted next displacement (n, D) after ``displacement`` (n, D), and the new ``h, c``."""
        h, c = self.cell.step(displacement / self.scale, h, c)
        return self.scale * (h @ self.head_w + self.head_b), h, c

    def residual_variance(self, tracks: Sequence[FloatArray]) -> float:
        """Mean over steps and axes of ``(z_{t+1} − z_t − Δ̂_t)²`` on ``tracks``, all tracks at once."""
        inputs, targets, mask = sequences(tracks, self.scale)
        h = c = np.zeros((len(inputs), self.cell.hidden))
        squared = np.zeros(mask.shape)
        for t in range(mask.shape[1]):
            predicted, h, c = self.step(inputs[:, t] * self.scale, h, c)
            squared[:, t] = ((targets[:, t] * self.scale - predicted) ** 2).mean(axis=1)
        return float((squared * mask).sum() / mask.sum())


# -- the predictor -------------------------------------------------------------------------------
@dataclass(frozen=True)
class StepState(BatchState):
    """Per-track state (first axis: tracks).

    Attributes:
        h, c: The LSTM state after the last input (n, H).
        last: The last position the network consumed (n, D).
        step: The displacement it predicts from there (n, D).
        mean: The current estimate (n, D): the last measurement, or the prediction while coasting.
        var: Its variance per axis (n,).
        misses: Consecutive frames coasted (n,).
    """

    h: FloatArray
    c: FloatArray
    last: FloatArray
    step: FloatArray
    mean: FloatArray
    var: FloatArray
    misses: FloatArray


class LearnedStepPredictor:
    """The learned step model as a Predictor (no optional capability: the core only).

    ``predict``: ``ẑ = last + Δ̂`` with the learned covariance ``s (1 + k) I`` (``s`` the model's
    residual variance, ``k`` the frames coasted); ``update`` feeds the network the measurement,
    or, for a track that coasts, its own prediction, so every track advances one step a frame.

    Args:
        weights: The model file (path with or without suffix) or a loaded ``ModelFile``.

    Raises:
        ModelFileError: a missing file, another kind or dimension, or tensors of the wrong shape.
    """

    def __init__(self, weights: str | os.PathLike[str] | ModelFile):
        model = weights if isinstance(weights, ModelFile) else load_model(weights, kind=KIND, dim=2)
        self.net = StepNetwork.from_model(model)
        self.residual_var = float(model.meta["calibration"]["residual_var"])
        self._r = 0.0

    def reset(self, spec: SensorSpec) -> None:
        """Bind to ``spec``: a measurement's variance ``σ_n²``."""
        if spec.dim != 2:
            raise ValueError(f"{NAME} predicts 2-D positions, the sensor has dim {spec.dim}")
        self._r = max(float(spec.noise_std), 1e-6) ** 2

    def start(self, z: NDArray[np.floating]) -> StepState:
        """New tracks at ``z`` (n, 2): one network step on a zero displacement."""
        z = np.array(z, dtype=np.float64).reshape(-1, 2)
        n, hidden = len(z), self.net.cell.hidden
        step, h, c = self.net.step(np.zeros_like(z), np.zeros((n, hidden)), np.zeros((n, hidden)))
        return StepState(h, c, z, step, z, np.full(n, self._r), np.zeros(n))

    def predict(self, state: StepState) -> tuple[StepState, Gaussian]:
        """Every track one frame on: ``N(last + Δ̂, s (1 + k) I)``."""
        mean, var = state.last + state.step, self.residual_var * (1.0 + state.misses)
        predicted = StepState(state.h, state.c, state.last, state.step, mean, var, state.misses)
        return predicted, self._gaussian(mean, var)

    def update(self, state: StepState, z: NDArray[np.floating], seen: NDArray[np.bool_]) -> StepState:
        """Feed every track its measurement (``seen``) or its prediction (coasting)."""
        seen = np.asarray(seen, dtype=bool)
        position = np.where(seen[:, None], np.asarray(z, dtype=np.float64), state.mean)
        step, h, c = self.net.step(position - state.last, state.h, state.c)
        var = np.where(seen, self._r, state.var)
        return StepState(h, c, position, step, position, var, np.where(seen, 0.0, state.misses + 1))

    def estimate(self, state: StepState) -> Gaussian:
        """The current estimate of every track."""
        return self._gaussian(state.mean, state.var)

    @staticmethod
    def _gaussian(mean: FloatArray, var: FloatArray) -> Gaussian:
        return Gaussian(mean, var[:, None, None] * np.eye(mean.shape[1]))


def learned_step(*, weights: str | os.PathLike[str]) -> Predictor:
    """The factory registered as `NAME`: ``weights`` is the model file."""
    return LearnedStepPredictor(weights)


def register() -> None:
    """Register `learned_step` as `NAME`."""
    register_predictor(NAME, learned_step)


def track(model: str | os.PathLike[str], steps: int, seed: int = 1000) -> dict[str, Any]:
    """Check the predictor of ``model`` and track ``steps`` frames of `ENV_ID` (an episode
    the data did not come from: ``seed``) with gnn; the episode metrics."""
    import gymnasium as gym

    import track_envs  # noqa: F401  (registers the envs)
    from agents import make_agent, run_episode
    from predictors import make_predictor
    from track_envs.testing import check_predictor
    from track_envs.wrappers import TrackingMetrics

    register()
    env = TrackingMetrics(gym.make(ENV_ID, max_episode_steps=steps))
    spec = env.get_wrapper_attr("sensor_spec")
    check_predictor(make_predictor(NAME, weights=model), spec)
    agent = make_agent("gnn", predictor=NAME, weights=model)
    metrics: dict[str, Any] = run_episode(env, agent, seed=seed).metrics
    print(f"{ENV_ID} + gnn({NAME}), {steps} frames: mean error {metrics['mean_error']:.3f}")
    return metrics


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Train (unless ``--model`` is given), save, load and track; the episode metrics."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="directory for the model file (default: a temporary one)")
    parser.add_argument("--model", help="track with this model file instead of training one")
    parser.add_argument("--hidden", type=int, default=12, help="LSTM units (default 12)")
    parser.add_argument("--epochs", type=int, default=150, help="training epochs (default 150)")
    parser.add_argument("--episodes", type=int, default=24, help="training episodes = tracks (default 24)")
    parser.add_argument("--train-steps", type=int, default=60, help="frames per training track (default 60)")
    parser.add_argument("--steps", type=int, default=300, help="frames to track (default 300)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the data and the training (default 0)")
    args = parser.parse_args(argv)
    if args.model is not None:
        return track(args.model, args.steps)
    with tempfile.TemporaryDirectory(prefix="extend-learned-") as scratch:
        out = args.out if args.out is not None else scratch
        model = train(
            out,
            hidden=args.hidden,
            epochs=args.epochs,
            episodes=args.episodes,
            steps=args.train_steps,
            seed=args.seed,
        )
        return track(model, args.steps)


if __name__ == "__main__":
    main()
