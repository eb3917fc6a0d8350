"""The belt LSTMs' float32 step (predictors/belt_lstm/cell.py) and per-frame inputs
(predictors/belt_lstm/features.py): the same bits as the numpy forms they replace, and every
network step of a learned predictor inside the frame's BLAS limit (track_envs/infra/blas_threads.py)."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import track_envs  # noqa: F401
from predictors import make_predictor
from predictors.belt_lstm.cell import RowsLSTMCell
from predictors.displacement_lstm.inference import DisplacementLSTM
from predictors.displacement_lstm.model import LSTMDisplacement
from predictors.lstm_cell import FusedLSTMCell
from track_envs.infra.blas_threads import blas_info, set_frame_threads


@pytest.fixture(scope="module")
def spec():
    return gym.make("BeltSorter-v0").unwrapped.sensor_spec


def _tracks(spec, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    low, size = np.asarray(spec.region_low), np.asarray(spec.region_size)
    start = low + rng.random((n, 2)) * size * [0.8, 1.0]
    return np.stack([start + np.array([0.011 * k, 0.002 * k]) for k in range(4)])


@pytest.mark.parametrize("n", [1, 7, 150, 600])
@pytest.mark.parametrize(("x_dtype", "state_dtype"), [("f8", "f4"), ("f4", "f4"), ("f8", "f8")])
def test_rows_cell_gives_the_bits_of_the_fused_cell(n, x_dtype, state_dtype) -> None:
    net = make_predictor("nll-lstm").net
    rng = np.random.default_rng(n)
    for layer in (net.layer1, net.layer2):
        assert isinstance(layer, RowsLSTMCell)
        reference = FusedLSTMCell(layer.w, layer.n_in)
        x = (3 * rng.standard_normal((n, layer.n_in))).astype(x_dtype)
        h = rng.standard_normal((n, layer.hidden)).astype(state_dtype)
        c = (4 * rng.standard_normal((n, layer.hidden))).astype(state_dtype)
        for got, want in zip(layer.step(x, h, c), reference.step(x, h, c), strict=True):
            assert got.dtype == want.dtype
            np.testing.assert_array_equal(got, want)


def test_rows_cell_takes_numpy_products_only() -> None:
    cell = make_predictor("nll-lstm").net.layer1
    with pytest.raises(ValueError, match="matmul is 'ordered'"):
        RowsLSTMCell.of(dataclasses.replace(FusedLSTMCell(cell.w, cell.n_in), matmul="ordered"))


def test_compiled_inputs_give_the_bits_of_the_numpy_form(spec) -> None:
    f = dataclasses.replace(
        make_predictor("nll-lstm").features, low=np.asarray(spec.region_low, dtype=np.float64)
    )
    z = _tracks(spec, 50)

    def reference(z_now, z_prev):
        u = (z_now - f.low) / f.size
        du = np.zeros_like(u) if z_prev is None else u - (z_prev - f.low) / f.size
        return (np.concatenate([u, du], axis=-1) - f.in_mean) / f.in_std

    np.testing.assert_array_equal(f.inputs(z[1], z[0]), reference(z[1], z[0]))
    np.testing.assert_array_equal(f.inputs(z[1], None), reference(z[1], None))
    # not a float64 array: the numpy form itself
    np.testing.assert_array_equal(f.inputs(z[1].tolist(), None), reference(z[1], None))


def _run(predictor, spec, z, seen):
    predictor.reset(spec, rng=np.random.default_rng(0))
    state = predictor.start(z[0])
    out = []
    for k in range(1, len(z)):
        state, prediction = predictor.predict(state)
        state = predictor.update(state, z[k], seen)
        out += [prediction.mean, prediction.cov]
    return out


@pytest.mark.parametrize("kind", ["lstm", "nll-lstm", "mc-lstm"])
def test_belt_steps_run_on_one_blas_thread_with_the_same_bits(kind, spec, monkeypatch) -> None:
    z = _tracks(spec, 150)
    seen = np.arange(150) % 5 != 0
    inside: list[set[int]] = []
    step = RowsLSTMCell.step

    def recording(self, x, h, c):
        inside.append({int(i["num_threads"]) for i in blas_info()})
        return step(self, x, h, c)

    blas_info()
    with threadpool_limits(2, user_api="blas"):
        monkeypatch.setattr(RowsLSTMCell, "step", recording)
        pinned = _run(make_predictor(kind), spec, z, seen)
        assert inside and all(s == {1} for s in inside)
        try:
            set_frame_threads(None)  # BLAS on its own two threads
            inside.clear()
            free = _run(make_predictor(kind), spec, z, seen)
            assert inside and all(s == {2} for s in inside)
        finally:
            set_frame_threads(1)
    for a, b in zip(pinned, free, strict=True):
        np.testing.assert_array_equal(a, b)


def test_displacement_lstm_frame_runs_on_one_blas_thread(monkeypatch) -> None:
    inside: list[set[int]] = []
    frame = DisplacementLSTM.frame

    def recording(self, *args, **kwargs):
        inside.append({int(i["num_threads"]) for i in blas_info()})
        return frame(self, *args, **kwargs)

    monkeypatch.setattr(DisplacementLSTM, "frame", recording)
    x = np.cumsum(np.random.default_rng(0).normal(0.2, 0.05, (200, 6, 2)), axis=1)
    model = LSTMDisplacement()
    blas_info()
    with threadpool_limits(2, user_api="blas"):
        for t in range(1, 7):
            model.displacement(x[:, :t])
    assert len(inside) == 6 and all(s == {1} for s in inside)


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_compiled_nll_prediction_gives_the_bits_of_the_numpy_form(precision, spec) -> None:
    from predictors.belt_lstm.predictor import LSTMPredictor

    base = make_predictor("nll-lstm")
    p = LSTMPredictor("nll-lstm", base.model, precision=precision)
    p.calibration_scale = 1.7
    z = _tracks(spec, 40)
    p.reset(spec, rng=np.random.default_rng(0))
    state = p.update(p.predict(p.start(z[0]))[0], z[1], np.ones(40, dtype=bool))
    got = p.predict(state)[1]
    f, d = p._features, 2
    mean = f.position(state.z_prev, state.out[:, :d])
    var = np.exp(state.out[:, d:]) * f.variance_scale()
    cov = np.zeros((40, d, d))
    cov[:, [0, 1], [0, 1]] = var
    np.testing.assert_array_equal(got.mean, mean)
    np.testing.assert_array_equal(got.cov, p.calibration_scale * cov)
