"""The one inference LSTM cell: numpy and compiled steps equal torch's LSTM, and each learned family
(belt, displacement, pose) run through it equals its torch network to 1e-6."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from predictors.belt_lstm.inference import FastLSTMWeights, LSTMWeights
from predictors.belt_lstm.network import BeltLSTMNet
from predictors.displacement_lstm.network import DisplacementLSTMNet
from predictors.lstm_cell import (
    LSTMCellWeights,
    cell_step,
    cell_step_rows,
    sigmoid,
    sigmoid_exp,
    sigmoid_tanh,
    tanh_exp,
)
from predictors.pose_lstm.network import PosePredictorNet


def _saturate(net: torch.nn.Module, factor: float = 3.0) -> torch.nn.Module:
    """Scale every parameter so that some gates saturate."""
    with torch.no_grad():
        for p in net.parameters():
            p.mul_(factor)
    return net.eval()


def _torch_lstm(n_in: int, hidden: int, dtype: torch.dtype, seed: int = 0) -> torch.nn.LSTM:
    torch.manual_seed(seed)
    net = _saturate(torch.nn.LSTM(n_in, hidden, batch_first=True).to(dtype))
    assert isinstance(net, torch.nn.LSTM)
    return net


def _weights(net: torch.nn.LSTM, dtype: type) -> LSTMCellWeights:
    tensors = {k: v.detach().numpy() for k, v in net.state_dict().items()}
    return LSTMCellWeights.from_tensors(tensors, "", "_l0", dtype=dtype)


@pytest.mark.parametrize(
    ("dtype", "tdtype", "atol"), [(np.float64, torch.float64, 1e-12), (np.float32, torch.float32, 1e-6)]
)
def test_numpy_step_equals_torch_lstm(dtype: type, tdtype: torch.dtype, atol: float) -> None:
    net = _torch_lstm(5, 16, tdtype)
    x = np.random.default_rng(0).normal(0, 1.5, (40, 12, 5)).astype(dtype)
    with torch.no_grad():
        seq, (_, c_t) = net(torch.from_numpy(x))
    cell = _weights(net, dtype)
    assert (cell.inputs, cell.hidden) == (5, 16)
    h = np.zeros((40, 16), dtype)
    c = np.zeros((40, 16), dtype)
    for t in range(x.shape[1]):
        h, c = cell.step(x[:, t], h, c)
        assert h.dtype == c.dtype == dtype
        np.testing.assert_allclose(h, seq[:, t].numpy(), rtol=0, atol=atol, err_msg=f"step {t}")
    np.testing.assert_allclose(c, c_t[0].numpy(), rtol=0, atol=atol)


def test_fused_float32_step_equals_torch_lstm() -> None:
    net = _torch_lstm(3, 24, torch.float32, seed=1)
    x = np.random.default_rng(1).normal(0, 1.5, (50, 10, 3)).astype(np.float32)
    with torch.no_grad():
        seq, (_, c_t) = net(torch.from_numpy(x))
    fused = _weights(net, np.float64).fused()
    assert fused.hidden == 24 and fused.w.dtype == np.float32
    h = np.zeros((50, 24), np.float32)
    c = np.zeros((50, 24), np.float32)
    for t in range(x.shape[1]):
        h, c = fused.step(x[:, t], h, c)
        np.testing.assert_allclose(h, seq[:, t].numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")
    np.testing.assert_allclose(c, c_t[0].numpy(), rtol=0, atol=1e-6)


def test_compiled_steps_equal_torch_lstm() -> None:
    net = _torch_lstm(4, 8, torch.float64, seed=2)
    x = np.random.default_rng(2).normal(0, 1.5, (6, 9, 4))
    with torch.no_grad():
        seq, _ = net(torch.from_numpy(x))
    cell = _weights(net, np.float64)
    w = cell.stacked()
    assert w.shape == (12, 32) and w.flags.c_contiguous
    h_row, c_row = np.zeros((6, 8)), np.zeros((6, 8))  # one row at a time (cell_step)
    h_rows, c_rows = np.zeros((6, 8)), np.zeros((6, 8))  # all rows (cell_step_rows)
    a = np.empty(32)
    for t in range(x.shape[1]):
        for k in range(6):
            cell_step(np.concatenate([x[k, t], h_row[k]]), w, cell.b, h_row[k], c_row[k], a)
        cell_step_rows(np.ascontiguousarray(x[:, t]), h_rows, c_rows, cell.w_ih, cell.w_hh, cell.b)
        np.testing.assert_allclose(h_row, seq[:, t].numpy(), rtol=0, atol=1e-12)
        np.testing.assert_allclose(h_rows, seq[:, t].numpy(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c_row, c_rows, rtol=0, atol=1e-12)


def test_the_sigmoid_formulas_agree_and_do_not_overflow() -> None:
    a = np.concatenate([np.linspace(-40, 40, 801), [-1e300, -800.0, 800.0, 1e300]])
    exact = np.where(
        a >= 0, 1.0 / (1.0 + np.exp(-np.abs(a))), np.exp(-np.abs(a)) / (1.0 + np.exp(-np.abs(a)))
    )
    with np.errstate(all="raise"):
        np.testing.assert_allclose(sigmoid(a), exact, rtol=1e-15, atol=1e-16)
    compiled_tanh = np.array([sigmoid_tanh(v) for v in a])
    compiled_exp = np.array([sigmoid_exp(v) for v in a])
    np.testing.assert_allclose(compiled_tanh, exact, rtol=1e-15, atol=1e-16)
    np.testing.assert_allclose(compiled_exp, exact, rtol=1e-15, atol=1e-16)
    np.testing.assert_allclose([tanh_exp(v) for v in a], np.tanh(a), rtol=0, atol=1e-15)
    assert sigmoid(np.array([0.0], np.float32)).dtype == np.float32


def test_bad_weights_are_named() -> None:
    with pytest.raises(KeyError, match=r"lstm\.bias_hh_l0"):
        LSTMCellWeights.from_tensors({"lstm.weight_ih_l0": np.zeros((8, 3))}, "lstm.", "_l0")
    with pytest.raises(ValueError, match=r"\(8, 3\)"):
        LSTMCellWeights.from_torch(np.zeros((8, 3)), np.zeros((8, 3)), np.zeros(8), np.zeros(8))


# -- each family against its torch network --------------------------------------------------------


@pytest.mark.parametrize("masked", [False, True])
def test_belt_network_numpy_equals_torch(masked: bool) -> None:
    torch.manual_seed(3)
    net = _saturate(BeltLSTMNet("nll-lstm", 2, hidden=(16, 12), dropout=0.0), 2.0)
    assert isinstance(net, BeltLSTMNet)
    reference = LSTMWeights.from_tensors(net.numpy_weights())
    fast = FastLSTMWeights.from_weights(reference)
    rng = np.random.default_rng(3)
    n = 30
    s64, s32 = reference.zero_state(n), fast.zero_state(n)
    state = net.zero_state(n)
    for t in range(8):
        x = rng.normal(0, 1.5, (n, 4))
        masks = None
        if masked:
            masks = tuple((rng.random((n, w)) < 0.8) / 0.8 for w in net.mask_sizes())
        with torch.no_grad():
            tm = None if masks is None else [torch.as_tensor(m, dtype=torch.float32) for m in masks]
            out_t, state = net.step(torch.as_tensor(x, dtype=torch.float32), state, tm)
        out64, s64 = reference.step(x, s64, masks)
        out32, s32 = fast.step(
            x.astype(np.float32), s32, None if masks is None else tuple(m.astype(np.float32) for m in masks)
        )
        np.testing.assert_allclose(out64, out_t.numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")
        np.testing.assert_allclose(out32, out_t.numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")
        for mine, theirs in zip(s64, state, strict=True):
            np.testing.assert_allclose(mine, theirs.numpy(), rtol=0, atol=1e-6)


def test_belt_rollout_cell_equals_torch() -> None:
    """The compiled cell with the stacked weights of the belt roll-out kernel equals torch's cells."""
    torch.manual_seed(4)
    net = _saturate(BeltLSTMNet("lstm", 2, hidden=(16, 12)), 2.0)
    assert isinstance(net, BeltLSTMNet)
    reference = LSTMWeights.from_tensors(net.numpy_weights())
    layers = [(layer.stacked(), layer.b) for layer in (reference.layer1, reference.layer2)]
    rng = np.random.default_rng(4)
    x = rng.normal(0, 1.5, (5, 7, 4))
    state = net.zero_state(5)
    h1, c1, h2, c2 = (np.zeros((5, w)) for w in (16, 16, 12, 12))
    a1, a2 = np.empty(64), np.empty(48)
    for t in range(x.shape[1]):
        with torch.no_grad():
            _, state = net.step(torch.as_tensor(x[:, t], dtype=torch.float32), state)
        for k in range(5):
            cell_step(np.concatenate([x[k, t], h1[k]]), *layers[0], h1[k], c1[k], a1)
            cell_step(np.concatenate([h1[k], h2[k]]), *layers[1], h2[k], c2[k], a2)
        for mine, theirs in zip((h1, c1, h2, c2), state, strict=True):
            np.testing.assert_allclose(mine, theirs.numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")


def test_displacement_network_compiled_cell_equals_torch() -> None:
    """The compiled rows step of the displacement frame, with the network's weights, equals torch."""
    torch.manual_seed(5)
    net = _saturate(DisplacementLSTMNet())
    assert isinstance(net, DisplacementLSTMNet)
    cell = LSTMCellWeights.from_tensors(net.numpy_weights(), "lstm.", "_l0")
    rng = np.random.default_rng(5)
    h, c = np.zeros((9, net.hidden)), np.zeros((9, net.hidden))
    state = None
    for t in range(20):
        x = rng.normal(0, 1.5, (9, 2))
        with torch.no_grad():
            _, state = net.step(torch.as_tensor(x, dtype=torch.float32), state)
        cell_step_rows(x, h, c, cell.w_ih, cell.w_hh, cell.b)
        np.testing.assert_allclose(h, state[0].numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")
        np.testing.assert_allclose(c, state[1].numpy(), rtol=0, atol=1e-6, err_msg=f"step {t}")


def test_pose_network_numpy_equals_torch() -> None:
    """The pose predictor's LSTM (3 inputs, 64 units) through the numpy cell equals torch's, float32."""
    torch.manual_seed(6)
    net = _saturate(PosePredictorNet(), 2.0)
    assert isinstance(net, PosePredictorNet)
    cell = LSTMCellWeights.from_tensors(net.numpy_weights(), "lstm.", "_l0", dtype=np.float32)
    x = np.random.default_rng(6).normal(0, 1.5, (64, 10, 3)).astype(np.float32)
    with torch.no_grad():
        _, (h_t, c_t) = net.lstm(torch.from_numpy(x))
    for step in (cell.step, cell.fused().step):
        h = np.zeros((64, net.hidden), np.float32)
        c = np.zeros((64, net.hidden), np.float32)
        for t in range(x.shape[1]):
            h, c = step(x[:, t], h, c)
        np.testing.assert_allclose(h, h_t[0].numpy(), rtol=0, atol=1e-6)
        np.testing.assert_allclose(c, c_t[0].numpy(), rtol=0, atol=1e-6)
    for matmul in ("numpy", "torch"):  # the predictor's path: whole windows, blocks of rows
        h, c = cell.fused(matmul).sequence(x, block=48)
        np.testing.assert_allclose(h, h_t[0].numpy(), rtol=0, atol=1e-6)
        np.testing.assert_allclose(c, c_t[0].numpy(), rtol=0, atol=1e-6)


@pytest.mark.parametrize("matmul", ["numpy", "torch", "ordered"])
def test_the_blocked_sequence_equals_the_steps_and_torch(matmul: str) -> None:
    """`FusedLSTMCell.sequence` (blocks of rows, transposed layout) equals `step` run
    L times and torch's LSTM to float32 rounding, from the zero state and from a given one, for
    blocks that do and do not divide the rows."""
    net = _torch_lstm(3, 20, torch.float32, seed=7)
    rng = np.random.default_rng(7)
    x = rng.normal(0, 1.5, (70, 6, 3)).astype(np.float32)
    h0, c0 = (rng.normal(0, 0.5, (70, 20)).astype(np.float32) for _ in range(2))
    cell = _weights(net, np.float64).fused(matmul)
    for state in (None, (h0, c0)):
        with torch.no_grad():
            hc = None if state is None else tuple(torch.from_numpy(a)[None] for a in state)
            _, (h_t, c_t) = net(torch.from_numpy(x), hc)
        h, c = (np.zeros((70, 20), np.float32),) * 2 if state is None else state
        for t in range(x.shape[1]):
            h, c = cell.step(x[:, t], h, c)
        for block in (1, 16, 70, 512):
            h_s, c_s = cell.sequence(x, state, block=block)
            assert h_s.dtype == c_s.dtype == np.float32 and h_s.shape == c_s.shape == (70, 20)
            np.testing.assert_allclose(h_s, h, rtol=0, atol=1e-6, err_msg=f"block {block}")
            np.testing.assert_allclose(c_s, c, rtol=0, atol=1e-6, err_msg=f"block {block}")
            if matmul == "ordered":  # a fixed summation order: the same bits in either layout
                np.testing.assert_array_equal(h_s, h, err_msg=f"block {block}")
                np.testing.assert_array_equal(c_s, c, err_msg=f"block {block}")
            np.testing.assert_allclose(h_s, h_t[0].numpy(), rtol=0, atol=1e-6, err_msg=f"block {block}")
            np.testing.assert_allclose(c_s, c_t[0].numpy(), rtol=0, atol=1e-6, err_msg=f"block {block}")
    empty = cell.sequence(np.zeros((0, 4, 3), np.float32))
    assert empty[0].shape == (0, 20)


def test_the_matmuls_agree_and_bad_arguments_are_named() -> None:
    cell = _weights(_torch_lstm(3, 8, torch.float32, seed=8), np.float64)
    x = np.random.default_rng(8).normal(0, 1.5, (9, 3)).astype(np.float32)
    zero = np.zeros((9, 8), np.float32)
    for a, b in zip(cell.fused().step(x, zero, zero), cell.fused("torch").step(x, zero, zero), strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)
    with pytest.raises(
        ValueError, match=r"matmul must be one of \('numpy', 'torch', 'ordered'\), got 'blas'"
    ):
        cell.fused("blas")
    with pytest.raises(ValueError, match=r"threads must be an integer >= 1, got 0"):
        dataclasses.replace(cell.fused("ordered"), threads=0)
    fused = cell.fused()
    with pytest.raises(ValueError, match=r"\(n, L, 3\).*\(9, 3\)"):
        fused.sequence(x)
    with pytest.raises(ValueError, match=r"block must be >= 1, got 0"):
        fused.sequence(x[:, None], block=0)
    with pytest.raises(ValueError, match=r"state must be \(h, c\) of shape \(9, 8\)"):
        fused.sequence(x[:, None], (zero[:3], zero))
