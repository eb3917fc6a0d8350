"""The one training loop of every learned model: seeded Adam with step decay, L2, masking, tqdm.

Pollithy et al. (2020, Sec. IV-A) train with Adam (β₁ = 0.9, β₂ = 0.999, ε = 1e-7), an initial
learning rate of 0.01 decayed every 200 epochs, 1,000 epochs and an L2 penalty λ = 1e-5; these are
the defaults of [`TrainConfig`][predictors.training.TrainConfig] (the decay factor, which the paper does not
state, is 0.5). The loss is whatever the model family defines ([`LossFn`][predictors.training.loop.LossFn]),
evaluated on padded whole sequences with a validity mask, so backpropagation runs through whole tracks.

Determinism: parameters are initialised, batches shuffled and dropout masks drawn from torch
generators seeded by ``seed`` (the global torch RNG is forked, not consumed), and torch runs
single-threaded deterministic kernels on CPU, so one seed gives bit-identical weights on CPU.
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import torch
from torch import nn

from predictors.training.model_file import ModelFile

#: ``loss(model, batch, generator) -> scalar``: the data term of one (mini-)batch of tensors.
LossFn = Callable[[nn.Module, Sequence[torch.Tensor], torch.Generator], torch.Tensor]


@dataclass(frozen=True)
class TrainConfig:
    """Optimiser and schedule (defaults: Pollithy et al. 2020, Sec. IV-A).

    Attributes:
        epochs: Passes over the training tracks.
        lr: Initial learning rate.
        decay_every: Epochs between learning-rate decays.
        decay_rate: Factor applied at each decay.
        l2: Weight of ``Σ w²`` over all weights (not biases) added to the loss.
        batch_size: Tracks per optimiser step (``None``: all training tracks at once).
        seed: Seeds initialisation, shuffling and dropout masks.
        device: ``"cpu"`` or ``"cuda"``.
        betas, eps: Adam's parameters.
    """

    epochs: int = 1000
    lr: float = 0.01
    decay_every: int = 200
    decay_rate: float = 0.5
    l2: float = 1e-5
    batch_size: int | None = None
    seed: int = 0
    device: str = "cpu"
    betas: tuple[float, float] = (0.9, 0.999)
    eps: float = 1e-7

    def __post_init__(self) -> None:
        if not (isinstance(self.epochs, int) and self.epochs >= 1):
            raise ValueError(f"epochs must be an integer >= 1, got {self.epochs!r}")
        if not (math.isfinite(self.lr) and self.lr > 0):
            raise ValueError(f"lr must be a positive number, got {self.lr!r}")
        if not (isinstance(self.decay_every, int) and self.decay_every >= 1):
            raise ValueError(f"decay_every must be an integer >= 1, got {self.decay_every!r}")
        if not 0 < self.decay_rate <= 1:
            raise ValueError(f"decay_rate must be in (0, 1], got {self.decay_rate!r}")
        if not (math.isfinite(self.l2) and self.l2 >= 0):
            raise ValueError(f"l2 must be a number >= 0, got {self.l2!r}")
        if self.batch_size is not None and not (isinstance(self.batch_size, int) and self.batch_size >= 1):
            raise ValueError(f"batch_size must be None or an integer >= 1, got {self.batch_size!r}")
        if self.device not in ("cpu", "cuda"):
            raise ValueError(f"device must be 'cpu' or 'cuda', got {self.device!r}")
        if self.device == "cuda" and not torch.cuda.is_available():
            raise ValueError("device='cuda' but torch sees no CUDA device; use device='cpu'")


@dataclass
class History:
    """Losses per epoch and the wall time of a training run."""

    train_loss: list[float] = field(default_factory=list)
    validation_loss: list[float] = field(default_factory=list)
    best_epoch: int = -1
    wall_time_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON form (the last and best losses, not every epoch's)."""
        d = asdict(self)
        d["final_train_loss"] = self.train_loss[-1] if self.train_loss else None
        d["final_validation_loss"] = self.validation_loss[-1] if self.validation_loss else None
        del d["train_loss"], d["validation_loss"]
        return d


def seeded_init(build: Callable[[], nn.Module], seed: int) -> nn.Module:
    """Build a module with its parameters initialised from ``seed`` (global torch RNG untouched)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return build()


def l2_penalty(model: nn.Module) -> torch.Tensor:
    """``Σ w²`` over the weight matrices of ``model`` (biases are not penalised)."""
    terms = [p.pow(2).sum() for name, p in model.named_parameters() if "weight" in name]
    return torch.stack(terms).sum() if terms else torch.zeros(())


def fit(
    model: nn.Module,
    loss: LossFn,
    train: Sequence[torch.Tensor],
    validation: Sequence[torch.Tensor] | None,
    config: TrainConfig,
    *,
    progress: bool = True,
    description: str = "training",
    validation_loss: LossFn | None = None,
) -> History:
    """Train ``model`` in place on the tensors ``train`` (first axis: tracks); keep the best weights.

    Each epoch shuffles the tracks (generator seeded by ``config.seed``), steps Adam once per
    mini-batch on ``loss + l2 · Σ w²`` and evaluates ``loss`` on ``validation``; at the end the
    weights of the epoch with the lowest validation loss (the last epoch without validation data)
    are restored. A tqdm bar shows both losses. ``validation_loss`` (default: ``loss``) scores the
    validation tensors, for a training loss that augments its batches.

    Raises:
        FloatingPointError: when a loss becomes NaN or infinite (naming the epoch).
    """
    from tqdm.auto import tqdm

    device = torch.device(config.device)
    deterministic = torch.are_deterministic_algorithms_enabled()
    threads = torch.get_num_threads()
    torch.use_deterministic_algorithms(True)
    if device.type == "cpu":
        torch.set_num_threads(1)
    try:
        model.to(device)
        train = [t.to(device) for t in train]
        validation = [t.to(device) for t in validation] if validation is not None else None
        generator = torch.Generator(device="cpu").manual_seed(config.seed)
        optimiser = torch.optim.Adam(model.parameters(), lr=config.lr, betas=config.betas, eps=config.eps)
        schedule = torch.optim.lr_scheduler.StepLR(optimiser, config.decay_every, gamma=config.decay_rate)
        n = train[0].shape[0]
        batch = config.batch_size or n
        history = History()
        best_state: dict[str, torch.Tensor] | None = None
        best = math.inf
        start = time.perf_counter()
        bar = tqdm(range(config.epochs), desc=description, disable=not progress, leave=False)
        for epoch in bar:
            model.train()
            order = torch.randperm(n, generator=generator).to(device)
            total = 0.0
            for lo in range(0, n, batch):
                rows = order[lo : lo + batch]
                optimiser.zero_grad()
                data_loss = loss(model, [t[rows] for t in train], generator)
                (data_loss + config.l2 * l2_penalty(model)).backward()
                optimiser.step()
                total += float(data_loss.detach()) * len(rows)
            schedule.step()
            history.train_loss.append(total / n)
            if validation is not None:
                model.eval()
                with torch.no_grad():
                    score_fn = validation_loss or loss
                    history.validation_loss.append(float(score_fn(model, validation, generator)))
            score = history.validation_loss[-1] if validation is not None else history.train_loss[-1]
            if not math.isfinite(history.train_loss[-1]) or not math.isfinite(score):
                raise FloatingPointError(f"{description}: the loss became {score} at epoch {epoch}")
            if score < best:
                best, history.best_epoch = score, epoch
                best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
            bar.set_postfix(train=f"{history.train_loss[-1]:.4g}", val=f"{score:.4g}", refresh=False)
        history.wall_time_s = time.perf_counter() - start
        if best_state is not None:
            model.load_state_dict(best_state)
        model.to("cpu").eval()
        return history
    finally:
        torch.use_deterministic_algorithms(deterministic)
        torch.set_num_threads(threads)


def trained_model_file(
    net: Any, *, kind: str, dim: int, normalisation: dict[str, Any], **meta: Any
) -> ModelFile:
    """The [`ModelFile`][predictors.training.ModelFile] of a trained network ``net`` (any module with
    ``architecture()`` and ``numpy_weights()``): its weights, its input normalisation, the
    package versions it was trained with, and ``meta``."""
    import numpy as np

    versions = {"python": platform.python_version(), "torch": torch.__version__, "numpy": np.__version__}
    return ModelFile(
        kind=kind,
        dim=dim,
        architecture=net.architecture(),
        tensors=net.numpy_weights(),
        meta={"normalisation": normalisation, "versions": versions, **meta},
    )
