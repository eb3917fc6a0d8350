"""Training the probabilistic pose predictor (Okada et al. 2020, Sec. III) on KeypointWalkers-v0.

Data ([`pose_windows_from_env`][predictors.pose_lstm.training.pose_windows_from_env]): episodes of a keypoint
env run with empty reports. For every person and frame ``t`` with the person in the truth, the *input* is the
person's detected poses at frames ``t − L … t − 1`` (``(x, y, v)`` per keypoint, ``(0, 0, 0)`` where the
detector missed the person or the keypoint, as the env's occlusions and misses make them) and the *target*
the true pose at ``t``. Poses are windows of 17 pointwise sequences; the split is by person, so no
person contributes to two sets; one training item is one pose window (17 sequences), so a
mini-batch of 30 holds 510 sequences.

Loss (eq. 8): the Gaussian negative log-likelihood of the residual ``r = (y_t − a) / scale`` from
the last visible coordinate ``a``, ``Σ_d ((μ_d − r_d)² / σ_d² + 2 log σ_d) / 2`` (eq. 8 with σ read
as the diagonal covariance σ²), averaged over the keypoints that are visible in the truth at ``t``
and have an anchor; the L2 term ``λ‖θ‖²`` is the training loop's. ``loss="mse"`` (the
ablation's "epistemic only" and "none" models, whose σ is not learnt) replaces it by the mean
squared error of ``μ`` alone, ``Σ_d (μ_d − r_d)² / 2`` over the two axes, with the same weights: eq.
(8) with σ fixed to 1 less its constant, so the ``log σ`` outputs get no gradient from the loss
(only the L2 term's decay) and the tracker uses ``fixed_sigma`` for them. Dropout 0.3 is active in
training (``dropout=0`` for the models without epistemic uncertainty). One model serves every
window length: each training batch is cut to its last ``ℓ`` steps, ``ℓ`` drawn uniformly from
``{min_window … L}`` by the loop's seeded generator (the paper trains one model per ``L``).

Metrics (test split, deterministic mean): mean error (px) of ``a + scale · μ`` against the truth,
the same for the last visible coordinate alone, the NLL, and the homoscedastic ``fixed_sigma``
(the RMS residual per axis on the validation split) that the ``aleatoric=False`` ablation uses.
After ``loss="mse"`` the NLL and mean σ are those of the untrained ``log σ`` outputs (no meaning);
``fixed_sigma`` is the σ of such a model.

Training recipe ([`predictors.training.recipes`][predictors.training.recipes]):
[`recipe`][predictors.pose_lstm.training.recipe] gives ``track train pose-lstm``,
[`train_command`][predictors.pose_lstm.training.train_command] runs it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from predictors.pose_lstm.network import PosePredictorNet
from predictors.pose_lstm.predictor import KIND, SCALE_PER_HEIGHT, window_features
from predictors.training.loop import History, LossFn, TrainConfig, fit, seeded_init, trained_model_file
from predictors.training.model_file import ModelFile
from predictors.training.recipes import TrainingRecipe
from predictors.training.settings import RecipeOption, TrainingSettings


@dataclass(frozen=True)
class PoseWindows:
    """Pose windows with targets.

    Attributes:
        windows: (N, 17, L, 3) float32 detected ``(x, y, v)`` per keypoint, oldest first.
        targets: (N, 17, 2) true keypoints at the next frame (px).
        visible: (N, 17) whether each target keypoint is visible in the truth.
        person: (N,) int64 person key (episode · 10⁶ + truth id), the unit of the split.
        scale: px per network unit.
        description: How the windows were made.
    """

    windows: NDArray[np.float32] = field(repr=False)
    targets: NDArray[np.float64] = field(repr=False)
    visible: NDArray[np.bool_] = field(repr=False)
    person: NDArray[np.int64] = field(repr=False)
    scale: float
    description: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.person)

    def take(self, rows: NDArray[np.intp]) -> PoseWindows:
        """The windows ``rows``."""
        return PoseWindows(
            self.windows[rows],
            self.targets[rows],
            self.visible[rows],
            self.person[rows],
            self.scale,
            self.description,
        )

    def split(
        self, seed: int, fractions: tuple[float, float, float] = (0.7, 0.15, 0.15)
    ) -> tuple[PoseWindows, ...]:
        """Train / validation / test windows, split by person with a seeded generator."""
        people = np.unique(self.person)
        order = np.random.default_rng(seed).permutation(people)
        a = round(fractions[0] * len(people))
        b = a + round(fractions[1] * len(people))
        parts = (order[:a], order[a:b], order[b:])
        return tuple(self.take(np.flatnonzero(np.isin(self.person, p))) for p in parts)


def pose_windows_from_env(
    env_id: str = "KeypointWalkers-v0",
    *,
    episodes: int,
    seed: int = 0,
    steps: int | None = None,
    window: int = 15,
    **env_kwargs: Any,
) -> PoseWindows:
    """Pose windows of ``episodes`` episodes (seeds ``seed, seed + 1, …``) of a keypoint env."""
    import gymnasium as gym

    import track_envs  # noqa: F401  (registers the envs)
    from track_envs.contracts.report import empty_report

    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    if not (isinstance(window, int) and window >= 2):
        raise ValueError(f"window must be an integer >= 2, got {window!r}")
    env = gym.make(env_id, **env_kwargs)
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    if env.observation_space["detections"].shape[1:] != (17, 3):  # type: ignore[index]
        raise ValueError(f"{env_id} is not a keypoint environment; pose windows need (17, 3) detections")
    report = empty_report(spec.max_tracks, (17, 2))
    parts: list[tuple[Any, ...]] = []
    for episode in range(episodes):
        obs, info = env.reset(seed=seed + episode)
        frames: list[tuple[Any, ...]] = []
        while True:
            frames.append(_frame(obs, info))
            if steps is not None and len(frames) >= steps:
                break
            obs, _, terminated, truncated, info = env.step(report)
            if terminated or truncated:
                break
        parts.append(_episode_windows(frames, window, episode))
    env.close()
    scale = float(spec.region_high[1] - spec.region_low[1]) * SCALE_PER_HEIGHT
    w, y, v, p = (np.concatenate(a) for a in zip(*parts, strict=True))
    description = {
        "source": "env",
        "env_id": env_id,
        "env_kwargs": dict(env_kwargs),
        "episodes": episodes,
        "seed": seed,
        "window": window,
        "windows": len(p),
    }
    return PoseWindows(w, y, v, p, scale, description)


def _frame(obs: Any, info: Any) -> tuple[Any, ...]:
    truth = info["truth"]
    live = truth["ids"] >= 0
    rows = np.flatnonzero(obs["mask"] == 1)
    det_ids = info["detection_ids"][rows]
    return (
        truth["ids"][live].copy(),
        truth["keypoints"][live].astype(np.float64),
        truth["keypoint_visible"][live].copy(),
        det_ids[det_ids >= 0].copy(),
        obs["detections"][rows[det_ids >= 0]].astype(np.float32),
    )


def _episode_windows(frames: list[tuple[Any, ...]], L: int, episode: int) -> tuple[Any, ...]:
    """The windows of one episode: dense (frames, people) tables, then a sliding window."""
    ids = np.unique(np.concatenate([f[0] for f in frames]))
    T, n = len(frames), len(ids)
    det = np.zeros((T + L, n, 17, 3), np.float32)  # L leading empty frames
    truth = np.zeros((T, n, 17, 2))
    vis = np.zeros((T, n, 17), bool)
    present = np.zeros((T, n), bool)
    for t, (tid, kp, kv, did, dz) in enumerate(frames):
        cols = np.searchsorted(ids, tid)
        truth[t, cols], vis[t, cols], present[t, cols] = kp, kv, True
        keep = np.isin(did, ids)
        det[L + t, np.searchsorted(ids, did[keep])] = dz[keep]
    det[..., 2] = (det[..., 2] > 0).astype(np.float32)
    det[..., :2] *= det[..., 2:3]
    # window of target frame t: det rows t … t + L − 1 (frames t − L … t − 1)
    win = np.lib.stride_tricks.sliding_window_view(det[: T + L - 1], L, axis=0)  # (T, n, 17, 3, L)
    any_seen = det[: T + L - 1, ..., 2].any(axis=-1)  # (T + L − 1, n)
    seen_window = np.lib.stride_tricks.sliding_window_view(any_seen, L, axis=0)[:T].any(axis=-1)
    t_idx, p_idx = np.nonzero(present & seen_window & vis.any(axis=-1))
    w = np.moveaxis(win[t_idx, p_idx], -1, -2)  # (N, 17, L, 3)
    return (
        np.ascontiguousarray(w, dtype=np.float32),
        truth[t_idx, p_idx],
        vis[t_idx, p_idx],
        episode * 1_000_000 + ids[p_idx].astype(np.int64),
    )


def pose_tensors(data: PoseWindows) -> list[torch.Tensor]:
    """``[windows (N, 17, L, 3), targets (N, 17, 2), visible (N, 17)]`` as float32 tensors (raw, px)."""
    return [
        torch.as_tensor(data.windows, dtype=torch.float32),
        torch.as_tensor(data.targets, dtype=torch.float32),
        torch.as_tensor(data.visible, dtype=torch.float32),
    ]


def _batch_terms(
    model: PosePredictorNet, batch: Any, scale: float, length: int, masks: torch.Tensor | None
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(μ, log σ, residual, weight)`` of the windows cut to their last ``length`` steps."""
    windows, targets, visible = batch
    w = windows[:, :, -length:].reshape(-1, length, 3).cpu().numpy()
    device = windows.device
    inputs, anchor, has = window_features(w, scale)
    inputs[:, 0, :2] = 0.0  # the first step has no predecessor in the window
    x = torch.from_numpy(inputs).to(device)
    r = (targets.reshape(-1, 2) - torch.from_numpy(anchor.astype(np.float32)).to(device)) / scale
    weight = visible.reshape(-1) * torch.from_numpy(has.astype(np.float32)).to(device)
    mu, log_sigma = model(x, masks)
    return mu, log_sigma, r, weight


def gaussian_nll(
    mu: torch.Tensor, log_sigma: torch.Tensor, r: torch.Tensor, weight: torch.Tensor
) -> torch.Tensor:
    """Eq. (8): weighted mean over sequences of ``Σ_d ((μ_d − r_d)² / σ_d² + 2 log σ_d) / 2``."""
    per = (((mu - r) * torch.exp(-log_sigma)).pow(2) + 2 * log_sigma).sum(dim=-1) / 2
    return (per * weight).sum() / weight.sum().clamp(min=1.0)


def mean_squared_error(mu: torch.Tensor, r: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """Weighted mean over sequences of ``Σ_d (μ_d − r_d)² / 2``: the mean over both axes of the squared
    error of ``μ``, i.e. [`gaussian_nll`][predictors.pose_lstm.training.gaussian_nll] with ``log σ = 0`` (σ
    plays no part)."""
    per = (mu - r).pow(2).sum(dim=-1) / 2
    return (per * weight).sum() / weight.sum().clamp(min=1.0)


#: The training losses of the pose predictor: eq. (8) and the squared error of μ alone.
LOSSES = ("nll", "mse")


def check_loss(loss: str) -> str:
    """``loss`` if it names a training loss ([`LOSSES`][predictors.pose_lstm.training.LOSSES]), else a
    ValueError naming the valid ones."""
    if loss not in LOSSES:
        raise ValueError(f"loss must be one of {', '.join(LOSSES)}, got {loss!r}")
    return loss


def pose_loss(scale: float, window: int, min_window: int, loss: str = "nll") -> LossFn:
    """``loss`` (eq. (8) ``"nll"`` or [`mean_squared_error`][predictors.pose_lstm.training.mean_squared_error]
    ``"mse"``) on batches cut to a random length in ``[min_window, window]`` (training mode only)."""
    mse = check_loss(loss) == "mse"

    def loss_fn(model: torch.nn.Module, batch: Any, generator: torch.Generator) -> torch.Tensor:
        assert isinstance(model, PosePredictorNet)
        length = window
        masks = None
        if model.training:
            length = int(torch.randint(min_window, window + 1, (1,), generator=generator))
            masks = model.draw_masks(batch[0].shape[0] * 17, generator)
        mu, log_sigma, r, weight = _batch_terms(model, batch, scale, length, masks)
        if mse:
            return mean_squared_error(mu, r, weight)
        return gaussian_nll(mu, log_sigma, r, weight)

    return loss_fn


def train_pose_model(
    train: PoseWindows,
    validation: PoseWindows | None,
    config: TrainConfig,
    *,
    dropout: float = 0.3,
    min_window: int = 3,
    loss: str = "nll",
    progress: bool = True,
) -> tuple[PosePredictorNet, History]:
    """Train a pose predictor with [`fit`][predictors.training.fit] on ``loss``
    ([`LOSSES`][predictors.pose_lstm.training.LOSSES]:
    ``"nll"`` eq. (8), ``"mse"`` the squared error of μ alone); the validation loss, which picks the
    kept epoch, is the same loss."""
    check_loss(loss)
    window = train.windows.shape[2]
    if not 1 <= min_window <= window:
        raise ValueError(f"min_window must be in [1, {window}] (the window length), got {min_window!r}")
    net = seeded_init(lambda: PosePredictorNet(dropout=dropout), config.seed)
    assert isinstance(net, PosePredictorNet)
    history = fit(
        net,
        pose_loss(train.scale, window, min_window, loss),
        pose_tensors(train),
        pose_tensors(validation) if validation is not None and len(validation) else None,
        config,
        progress=progress,
        description=KIND,
    )
    return net, history


def pose_metrics(
    net: PosePredictorNet, validation: PoseWindows, test: PoseWindows, length: int
) -> dict[str, Any]:
    """Test errors, NLL and the validation homoscedastic σ of the deterministic network at ``length``."""
    out: dict[str, Any] = {}
    net.eval()
    with torch.no_grad():
        for name, data in (("validation", validation), ("test", test)):
            mu, log_sigma, r, weight = _batch_terms(net, pose_tensors(data), data.scale, length, None)
            ok = weight > 0
            err = ((mu - r)[ok].norm(dim=-1) * data.scale).mean()
            out[f"{name}_mean_error_px"] = float(err)
            out[f"{name}_last_visible_error_px"] = float((r[ok].norm(dim=-1) * data.scale).mean())
            out[f"{name}_nll"] = float(gaussian_nll(mu, log_sigma, r, weight))
            out[f"{name}_mean_sigma"] = float(torch.exp(log_sigma[ok]).mean())
            if name == "validation":
                out["fixed_sigma"] = [float(v) for v in (mu - r)[ok].pow(2).mean(dim=0).sqrt()]
    out["window"] = length
    out["test_sequences"] = int(np.sum(test.visible))
    return out


def to_model_file(net: PosePredictorNet, scale_per_height: float, **meta: Any) -> ModelFile:
    """A [`ModelFile`][predictors.training.ModelFile] of a trained pose predictor."""
    normalisation = {"scale_per_height": scale_per_height}
    return trained_model_file(net, kind=KIND, dim=2, normalisation=normalisation, **meta)


# ------------------------------------------------------------------ the training recipe

#: ``track train pose-lstm``'s one-line help.
HELP = (
    "the SMC pose tracker's probabilistic pose predictor (KeypointWalkers-v0; the shipped ones: "
    "11-20 min on 2 CPU cores)"
)


def recipe(kind: str = KIND) -> TrainingRecipe:
    """The training recipe of the pose predictor (``track train pose-lstm``, with ``--loss``)."""
    if kind != KIND:
        raise ValueError(f"unknown pose predictor kind {kind!r}; valid names are {[KIND]}")
    return TrainingRecipe(KIND, HELP, train=train_command, options=(LOSS_OPTION,))


#: ``--loss``: the pose predictor's loss ([`LOSSES`][predictors.pose_lstm.training.LOSSES]).
LOSS_OPTION = RecipeOption(
    "loss",
    "nll",
    "nll: the Gaussian negative log-likelihood of eq. (8), mu and sigma learnt "
    "(default); mse: the squared error of mu alone (sigma is then the model file's "
    "fixed_sigma, the validation RMS residual)",
    choices=LOSSES,
)


def train_command(settings: TrainingSettings) -> Path:
    """``track train pose-lstm``: train on windows of a keypoint env's episodes (the data's
    ``env``), compute the test metrics and write ``settings.out``; returns the sidecar's path.

    Raises:
        ValueError: no ``--env`` (the predictor trains on a keypoint env's detections and truth).
    """
    from predictors.training.command import train_config, training_record
    from predictors.training.model_file import save_model

    data_settings = settings.data
    loss = settings.options.get("loss", LOSS_OPTION.default)
    if not data_settings.env:
        raise ValueError(
            "pose-lstm trains on a keypoint env's detections and truth; pass --env KeypointWalkers-v0"
        )
    start = time.perf_counter()
    window = 15 if data_settings.window is None else data_settings.window
    data = pose_windows_from_env(
        data_settings.env,
        episodes=data_settings.episodes,
        seed=data_settings.data_seed,
        steps=data_settings.steps,
        window=window,
        **data_settings.env_kwargs,
    )
    train, validation, test = data.split(settings.seed)
    s = {"train_windows": len(train), "validation_windows": len(validation), "test_windows": len(test)}
    print(f"{len(data)} pose windows of {len(np.unique(data.person))} people: {s}")
    config = train_config(settings)
    dropout = 0.3 if settings.dropout is None else settings.dropout
    net, history = train_pose_model(
        train,
        validation,
        config,
        dropout=dropout,
        min_window=settings.min_window,
        loss=loss,
        progress=settings.progress,
    )
    metrics = pose_metrics(net, validation, test, min(10, window))
    training = training_record(settings, config, history, min_window=settings.min_window, loss=loss)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    model = to_model_file(
        net, SCALE_PER_HEIGHT, training=training, data={**data.description, **s}, metrics=metrics
    )
    tensor_path, sidecar_path = save_model(settings.out, model)
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: mean error "
        f"{metrics['test_mean_error_px']:.3g} px (last visible coordinate: "
        f"{metrics['test_last_visible_error_px']:.3g} px), NLL {metrics['test_nll']:.3g}"
    )
    return sidecar_path
