"""The belt LSTM predictors: numpy inference equals torch, protocol behaviour, MC dropout, errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from predictors.belt_lstm.model_stats import spec_of
from predictors.belt_lstm.network import BeltLSTMNet, Features
from predictors.belt_lstm.predictor import LSTMPredictor
from predictors.belt_lstm.training import sequence_batch, to_model_file, train_belt_model
from predictors.training.data import TrackSplit
from predictors.training.loop import TrainConfig
from predictors.training.model_file import ModelFile, ModelFileError, save_model
from track_envs.testing import check_predictor

TINY = TrainConfig(epochs=3, decay_every=2, batch_size=64)


@pytest.fixture(scope="module")
def trained(belt_split: TrackSplit) -> dict[str, tuple[BeltLSTMNet, Features]]:
    out = {}
    for kind, dropout in (("lstm", 0.0), ("nll-lstm", 0.0), ("mc-lstm", 0.05), ("mc-lstm-0", 0.0)):
        net, features, _ = train_belt_model(
            kind.removesuffix("-0"), belt_split, TINY, dropout=dropout, progress=False
        )
        out[kind] = (net, features)
    return out


def _predictor(
    trained: dict,
    kind: str,
    split: TrackSplit,
    samples: int = 7,
    seed: int = 0,
    mc_inference: str = "grouped",
    precision: str = "float64",
) -> LSTMPredictor:
    net, features = trained[kind]
    model = to_model_file(net, features, mc={"tau": 50.0}, calibration={"scale": 1.0, "cov_scale": 1e-8})
    p = LSTMPredictor(net.kind, model, samples=samples, mc_inference=mc_inference, precision=precision)
    p.reset(spec_of(split.train, 1e-4), rng=np.random.default_rng(seed))
    return p


@pytest.mark.parametrize("kind", ["lstm", "nll-lstm"])
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_numpy_inference_equals_torch(
    kind: str, precision: str, trained: dict, belt_split: TrackSplit
) -> None:
    net, features = trained[kind]
    p = _predictor(trained, kind, belt_split, precision=precision)
    batch = sequence_batch(belt_split.test, features)
    steps = 6
    with torch.no_grad():
        reference = net(batch.inputs[:, :steps]).numpy()
    state = p.start(batch.positions[:, 0])
    np.testing.assert_allclose(state.out, reference[:, 0], atol=1e-6)
    for t in range(1, steps):
        state, _ = p.predict(state)
        state = p.update(state, batch.positions[:, t], np.ones(len(state), dtype=bool))
        np.testing.assert_allclose(state.out, reference[:, t], atol=1e-6, err_msg=f"step {t}")


def test_mc_masks_match_torch(trained: dict, belt_split: TrackSplit) -> None:
    """One MC sample of the numpy path equals the torch network run with the same masks."""
    net, features = trained["mc-lstm"]
    p = _predictor(trained, "mc-lstm", belt_split, samples=3, mc_inference="plain")
    batch = sequence_batch(belt_split.test, features)
    state = p.start(batch.positions[:, 0])
    state, _ = p.predict(state)
    state = p.update(state, batch.positions[:, 1], np.ones(len(state), dtype=bool))
    widths = np.cumsum(net.mask_sizes())[:-1]
    masks = [torch.as_tensor(m, dtype=torch.float32) for m in np.split(state.masks[:, 1], widths, axis=1)]
    with torch.no_grad():
        reference = net(batch.inputs[:, :2], masks).numpy()
    np.testing.assert_allclose(state.out[:, 1], reference[:, 1], atol=1e-6)


def test_mc_lstm_without_dropout_equals_lstm(trained: dict, belt_split: TrackSplit) -> None:
    lstm = _predictor(trained, "lstm", belt_split)
    mc = _predictor(trained, "mc-lstm-0", belt_split)
    z = sequence_batch(belt_split.test, trained["lstm"][1]).positions
    a, b = lstm.start(z[:, 0]), mc.start(z[:, 0])
    for t in range(1, 5):
        a, pa = lstm.predict(a)
        b, pb = mc.predict(b)
        np.testing.assert_allclose(pb.mean, pa.mean, rtol=0, atol=1e-12)
        seen = np.ones(len(a), dtype=bool)
        a, b = lstm.update(a, z[:, t], seen), mc.update(b, z[:, t], seen)


def test_same_rng_gives_the_same_mc_predictions(trained: dict, belt_split: TrackSplit) -> None:
    z = sequence_batch(belt_split.test, trained["mc-lstm"][1]).positions
    runs = []
    for seed in (3, 3, 4):
        p = _predictor(trained, "mc-lstm", belt_split, seed=seed)
        s = p.start(z[:, 0])
        s, pred = p.predict(s)
        runs.append(pred)
    assert np.array_equal(runs[0].mean, runs[1].mean) and np.array_equal(runs[0].cov, runs[1].cov)
    assert not np.array_equal(runs[0].cov, runs[2].cov)


@pytest.mark.parametrize("kind", ["lstm", "nll-lstm", "mc-lstm"])
def test_protocol_conformance(kind: str, trained: dict, belt_split: TrackSplit) -> None:
    check_predictor(_predictor(trained, kind, belt_split), spec_of(belt_split.train, 1e-4))


def test_coasting_feeds_the_prediction(trained: dict, belt_split: TrackSplit) -> None:
    p = _predictor(trained, "nll-lstm", belt_split)
    z = sequence_batch(belt_split.test, trained["nll-lstm"][1]).positions[:4]
    s = p.start(z[:, 0])
    s, pred = p.predict(s)
    missed = p.update(s, np.full_like(z[:, 1], np.nan), np.zeros(4, dtype=bool))
    fed = p.update(s, pred.mean, np.ones(4, dtype=bool))
    np.testing.assert_allclose(missed.out, fed.out, atol=1e-12)
    np.testing.assert_array_equal(p.estimate(missed).mean, pred.mean)


def test_nan_measurements_are_refused(trained: dict, belt_split: TrackSplit) -> None:
    p = _predictor(trained, "nll-lstm", belt_split)
    with pytest.raises(ValueError, match=r"measurement rows \[1\] hold NaN or inf"):
        p.start(np.array([[0.1, 0.1], [np.nan, 0.1]]))
    s = p.start(np.array([[0.1, 0.1], [0.2, 0.1]]))
    with pytest.raises(ValueError, match=r"measurement rows \[0\] hold NaN or inf"):
        p.update(s, np.array([[np.nan, 0.1], [0.2, 0.1]]), np.array([True, True]))


def test_weights_of_another_shape_are_named(trained: dict, tmp_path: Path) -> None:
    net, features = trained["nll-lstm"]
    model = to_model_file(net, features)
    tensors = dict(model.tensors)
    tensors["head.weight"] = np.zeros((4, 16), np.float32)
    save_model(tmp_path / "bad", ModelFile(model.kind, model.dim, model.architecture, tensors, model.meta))
    with pytest.raises(
        ModelFileError, match=r"'head.weight' has shape \(4, 16\), the architecture needs \(4, 32\)"
    ):
        LSTMPredictor("nll-lstm", tmp_path / "bad")
    save_model(tmp_path / "nll", model)
    with pytest.raises(ModelFileError, match=r"holds a 'nll-lstm' model; expected 'lstm'"):
        LSTMPredictor("lstm", tmp_path / "nll")


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match=r"kind must be one of \('lstm', 'nll-lstm', 'mc-lstm'\), got 'gru'"):
        LSTMPredictor("gru")
    with pytest.raises(ValueError, match=r"samples must be an integer >= 1, got 0"):
        LSTMPredictor("mc-lstm", samples=0)


def test_grouped_mc_equals_the_plain_t_sample_computation(trained: dict, belt_split: TrackSplit) -> None:
    """Computing each distinct dropout sample once gives the plain T-pass result (float64, 1e-12)."""
    net, features = trained["mc-lstm"]
    model = to_model_file(net, features, mc={"tau": 50.0}, calibration={"scale": 1.0})
    # masks at 1%: all four sample groups occur
    model = dataclasses.replace(model, architecture={**model.architecture, "dropout": 0.01})
    spec = spec_of(belt_split.train, 1e-4)
    plain = LSTMPredictor("mc-lstm", model, samples=40, mc_inference="plain", precision="float64")
    grouped = LSTMPredictor("mc-lstm", model, samples=40, mc_inference="grouped", precision="float64")
    plain.reset(spec, rng=np.random.default_rng(9))
    grouped.reset(spec, rng=np.random.default_rng(9))
    z = sequence_batch(belt_split.test, features).positions
    a, b = plain.start(z[:, 0]), grouped.start(z[:, 0])
    assert b.a_valid.any() and b.b_valid.any() and b.c_valid.any() and (b.n_clean > 0).any()
    rows = np.arange(len(z))  # the track of each state row
    for t in range(1, 6):
        a, pa = plain.predict(a)
        b, pb = grouped.predict(b)
        np.testing.assert_allclose(pb.mean, pa.mean, rtol=0, atol=1e-12)
        np.testing.assert_allclose(pb.cov, pa.cov, rtol=1e-9, atol=1e-18)
        seen = np.arange(len(a)) % 3 != 0  # some tracks coast
        a, b = plain.update(a, z[rows, t], seen), grouped.update(b, z[rows, t], seen)
        if t == 3:  # survivors and births: take and concat keep the groups
            keep = np.flatnonzero(np.arange(len(a)) % 2 == 0)
            a = type(a).concat([a.take(keep), plain.start(z[:4, t])])
            b = type(b).concat([b.take(keep), grouped.start(z[:4, t])])
            rows = np.concatenate([rows[keep], np.arange(4)])


@pytest.mark.parametrize("kind", ["nll-lstm", "mc-lstm"])
def test_survivors_and_births_equal_take_start_concat(
    kind: str, trained: dict, belt_split: TrackSplit
) -> None:
    p = _predictor(trained, kind, belt_split)
    z = sequence_batch(belt_split.test, trained[kind][1]).positions[:9, 0]
    state = p.predict(p.start(z[:6]))[0]
    keep = np.array([True, False, True, True, False, True])
    p.reset(p._spec, rng=np.random.default_rng(3))
    fused = p.survivors_and_births(state, keep, 4, z[6:])
    p.reset(p._spec, rng=np.random.default_rng(3))
    plain = type(state).concat([state.take(keep), p.start(z[6:])])
    for f in dataclasses.fields(plain):
        assert np.array_equal(getattr(fused, f.name), getattr(plain, f.name)), f.name
    assert len(p.survivors_and_births(state, keep, 4, z[:0])) == 4
    assert len(p.survivors_and_births(state, ~np.ones(6, bool), 0, z[6:])) == 3


@pytest.mark.parametrize(
    "kind, mc_inference",
    [("lstm", "grouped"), ("nll-lstm", "grouped"), ("mc-lstm", "grouped"), ("mc-lstm", "plain")],
)
def test_coast_equals_predict_then_update_with_nothing_seen(
    kind: str, mc_inference: str, trained: dict, belt_split: TrackSplit
) -> None:
    p = _predictor(trained, kind, belt_split, mc_inference=mc_inference)
    z = sequence_batch(belt_split.test, trained[kind][1]).positions[:5, :2]
    state = p.update(p.predict(p.start(z[:, 0]))[0], z[:, 1], np.ones(5, bool))
    a = b = state
    for _ in range(4):  # a roll-out of four frames
        a, pred_a = p.coast(a)
        moved, pred_b = p.predict(b)
        b = p.update(moved, np.full((5, 2), np.nan), np.zeros(5, bool))
        np.testing.assert_array_equal(pred_a.mean, pred_b.mean)
        np.testing.assert_array_equal(pred_a.cov, pred_b.cov)
        for f in dataclasses.fields(b):
            np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)
