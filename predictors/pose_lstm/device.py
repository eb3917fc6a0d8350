"""The pose predictor and the particles' OKS in torch on a device (a GPU when torch sees one).

``make_agent("pose-smc", device="cuda")`` swaps the CPU predictor
([`PosePredictor`][predictors.pose_lstm.predictor.PosePredictor]: compiled products in a fixed order, the
prefix tree) for [`TorchPosePredictor`][predictors.pose_lstm.device.TorchPosePredictor]: the network's own
``nn.LSTM`` (cuDNN on a GPU) over the distinct queues' windows and its FC head, on the device, with the LSTM
output kept there between the two; and the OKS of every candidate (filter, detection) pair's particles
([`paired_oks_torch`][predictors.pose_lstm.device.paired_oks_torch], the arithmetic of
[`track_envs.metrics.keypoints.paired_oks`][track_envs.metrics.keypoints.paired_oks]) on the device. The
random draws stay the tracker's numpy generator's (dropout masks are drawn on the CPU and moved), so the
tracks equal the CPU path's to float tolerance: the GEMMs of cuDNN and of the CPU path sum in other orders
(about 1e-6 in the LSTM output). Window features, the Gaussian draw, matching, resampling and
selection stay on the CPU (numpy; a few ms per frame at 10 people, P = 300).

``device="cpu"`` runs this torch path on the CPU, to check it where no GPU is. The CUDA path has
never run on a GPU: its test (``tests/agents/test_pose_smc_device.py``) runs only where torch sees
one, and the machines this project is tested on have none; only the same code on the CPU is tested.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.pose_lstm.predictor import LEAKY_SLOPE, LOG_SIGMA_RANGE, PosePredictor, dropout_masks
from predictors.training.model_file import ModelFile
from track_envs.metrics.keypoints import COCO_SIGMAS

FloatArray = NDArray[np.float64]


def torch_device(device: str) -> Any:
    """``torch.device(device)``, refusing a device torch cannot use here.

    Raises:
        ValueError: a name torch does not know, or a CUDA device without a GPU torch sees.
    """
    import torch

    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError) as err:
        raise ValueError(
            f"device must be a torch device name such as 'cuda' or 'cpu', got {device!r}"
        ) from err
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(
            f"device {device!r}: torch sees no GPU here (torch.cuda.is_available() is False); "
            "leave device unset for the CPU path"
        )
    if dev.type not in ("cpu", "cuda"):
        raise ValueError(f"device must be 'cpu' or a CUDA device ('cuda', 'cuda:0', …), got {device!r}")
    return dev


class TorchPosePredictor(PosePredictor):
    """[`PosePredictor`][predictors.pose_lstm.predictor.PosePredictor] computed by the network in torch on
    ``device`` (module docstring).

    [`encode`][predictors.pose_lstm.device.TorchPosePredictor.encode] and
    [`encode_shared`][predictors.pose_lstm.device.TorchPosePredictor.encode_shared] return the LSTM output as
    a torch tensor on the device, which [`head_of`][predictors.pose_lstm.device.TorchPosePredictor.head_of]
    takes; [`step`][predictors.pose_lstm.device.TorchPosePredictor.step] (the carried recurrence) returns
    numpy.

    Args:
        model: A ``pose-lstm`` model file (path or loaded).
        device: A torch device name ([`torch_device`][predictors.pose_lstm.device.torch_device]).
    """

    def __init__(self, model: ModelFile | str | os.PathLike[str], device: str) -> None:
        super().__init__(model)
        self.device = torch_device(device)
        self.net.to(self.device)

    def encode(self, inputs: NDArray[np.float32]) -> Any:
        import torch

        x = torch.from_numpy(np.ascontiguousarray(inputs, dtype=np.float32)).to(self.device)
        with torch.inference_mode():
            return self.net.lstm(x)[1][0][0]

    def encode_shared(self, inputs: NDArray[np.float32]) -> Any:
        """[`encode`][predictors.pose_lstm.device.TorchPosePredictor.encode] (on a GPU every window costs
        about the same as its distinct prefixes)."""
        return self.encode(inputs)

    def encode_leaves(self, inputs: NDArray[np.float32]) -> tuple[Any, NDArray[np.intp]]:
        """[`encode`][predictors.pose_lstm.device.TorchPosePredictor.encode] of every window, each window its
        own row."""
        return self.encode(inputs), np.arange(len(inputs))

    def head_of(
        self,
        h: Any,
        rng: np.random.Generator | None,
        epistemic: bool = True,
        rows: NDArray[np.intp] | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        import torch

        h = torch.as_tensor(h, dtype=torch.float32, device=self.device)
        m = len(h) if rows is None else len(rows)
        with torch.inference_mode():
            a = torch.nn.functional.leaky_relu(self.net.fc(h), LEAKY_SLOPE)
            if rows is not None:
                a = a[torch.from_numpy(np.asarray(rows, dtype=np.int64)).to(self.device)]
            if epistemic and self.dropout > 0:
                if rng is None:
                    raise ValueError("epistemic sampling needs a random generator")
                mask = dropout_masks(rng, m, self.fc_units, self.dropout)  # the CPU head's draws
                a = a * torch.from_numpy(mask).to(self.device)
            y = self.net.out(a)
            mu, log_sigma = y[:, :2], y[:, 2:].clamp(*LOG_SIGMA_RANGE)
        return mu.double().cpu().numpy(), torch.exp(log_sigma.double()).cpu().numpy()

    def step(
        self, x: NDArray[np.float32], state: tuple[NDArray[np.float32], NDArray[np.float32]] | None
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        import torch

        xt = torch.from_numpy(np.ascontiguousarray(x, dtype=np.float32)[:, None, :]).to(self.device)
        hc = None
        if state is not None:
            hc = tuple(
                torch.from_numpy(np.ascontiguousarray(s, dtype=np.float32))[None].to(self.device)
                for s in state
            )
        with torch.inference_mode():
            _, (h, c) = self.net.lstm(xt, hc)
        return h[0].cpu().numpy(), c[0].cpu().numpy()


def paired_oks_torch(
    a: NDArray, a_valid: NDArray, b: NDArray, b_valid: NDArray, area: NDArray, device: Any
) -> FloatArray:
    """[`track_envs.metrics.keypoints.paired_oks`][track_envs.metrics.keypoints.paired_oks] in float64 torch
    on ``device``: (c, P) OKS of the poses ``a`` (c, P, K, 2) of each row against the pose ``b`` (c, K, 2) of
    that row."""
    import torch

    def t(v: NDArray, dtype: Any = torch.float64) -> Any:
        return torch.as_tensor(np.ascontiguousarray(v), dtype=dtype, device=device)

    x, y, ar = t(a), t(b), t(area)
    valid = t(b_valid, torch.bool)[:, None] & t(a_valid, torch.bool)  # (c, P, K)
    var = (2 * t(COCO_SIGMAS)) ** 2
    d2 = ((x - y[:, None]) ** 2).sum(dim=-1)
    e = d2 / (var * 2 * (ar[:, None] + np.spacing(1)))[:, None]
    count = valid.sum(dim=2).clamp(min=1)
    return ((torch.exp(-e) * valid).sum(dim=2) / count).cpu().numpy()
