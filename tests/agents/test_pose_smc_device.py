"""pose-smc on a torch device: the same tracks as the CPU path to float tolerance."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from agents.pose.smc import PoseSmcAgent
from predictors.pose_lstm.device import TorchPosePredictor
from tests.agents.test_pose_smc import model, rollout  # noqa: F401  (the tiny trained model fixture)

GPU = pytest.mark.skipif(not torch.cuda.is_available(), reason="torch sees no GPU here")


def _same_tracks(a: list[dict], b: list[dict], atol: float) -> None:
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x["ids"], y["ids"])
        np.testing.assert_allclose(x["positions"], y["positions"], rtol=0, atol=atol)


@pytest.mark.parametrize("device", ["cpu", pytest.param("cuda", marks=GPU)])
@pytest.mark.parametrize("recurrence", ["window", "carried"])
def test_the_torch_path_tracks_as_the_cpu_path(model, device, recurrence):  # noqa: F811
    """The network's own LSTM and head in torch (and the OKS) on ``device`` against the compiled CPU
    path: the same ids, positions to 1e-3 px (the GEMMs sum in other orders, ~1e-6 in h)."""
    cpu = rollout(PoseSmcAgent(model, particles=40, recurrence=recurrence), 2, steps=15)
    agent = PoseSmcAgent(model, particles=40, recurrence=recurrence, device=device)
    assert isinstance(agent.motion.predictor, TorchPosePredictor)
    _same_tracks(rollout(agent, 2, steps=15), cpu, atol=1e-3)


def test_a_device_torch_cannot_use_is_named(model):  # noqa: F811
    with pytest.raises(ValueError, match=r"device must be 'cpu' or a CUDA device .*got 'meta'"):
        PoseSmcAgent(model, device="meta")
    with pytest.raises(ValueError, match=r"torch device name .*got 'gpu0'"):
        PoseSmcAgent(model, device="gpu0")
    if not torch.cuda.is_available():
        with pytest.raises(
            ValueError, match=r"device 'cuda': torch sees no GPU here .*is_available\(\) is False"
        ):
            PoseSmcAgent(model, device="cuda")
