"""The one-step oracle agent (agents/one_step.py) against the batch evaluation of the same tracks."""

from __future__ import annotations

from collections import defaultdict

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from predictors import make_predictor
from predictors.training.evaluate import one_step_predictions
from track_apps.bench.cells import Cell
from track_apps.bench.runner import run_cell


def _episode(agent, frames=60, **env_kwargs):
    env = gym.make("BeltSorter-v0", merge_touching=False, max_episode_steps=frames, **env_kwargs)
    obs, info = env.reset(seed=3)
    spec = env.unwrapped.sensor_spec
    agent.reset(spec, seed=3)
    seqs = defaultdict(list)
    while True:
        mask = obs["mask"] == 1
        for row in np.flatnonzero(mask & (info["detection_ids"] >= 0)):
            seqs[int(info["detection_ids"][row])].append(np.asarray(obs["detections"][row], dtype=np.float64))
        agent.observe_truth(info)
        report = agent.act(obs)
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    env.close()
    return spec, seqs, report


# float64 Kalman filters agree to rounding; the float32 LSTM to float32 accuracy (other batch sizes)
@pytest.mark.parametrize(("name", "rtol"), [("kf-cv", 1e-9), ("nll-lstm", 1e-4)])
def test_per_track_errors_equal_the_batch_evaluation(name, rtol):
    agent = make_agent("one-step", predictor=name, velocity_prior=False)
    spec, seqs, _ = _episode(agent)
    ids = sorted(i for i, s in seqs.items() if len(s) >= 2)
    predictor = make_predictor(name)
    predictor.reset(spec)
    result = one_step_predictions(predictor, [np.array(seqs[i]) for i in ids])
    np.testing.assert_allclose(agent.errors.per_track(), result.per_track_mean_error(), rtol=rtol, atol=1e-12)


def test_report_is_the_true_association():
    agent = make_agent("one-step", predictor="kf-ca")
    _, _, report = _episode(agent, frames=30)
    live = report["mask"] == 1
    assert live.sum() > 10
    assert np.all(report["ids"][live] >= 0)


def test_bench_cell_scores_the_predictor_and_keeps_e_mean_zero():
    cell = Cell("BeltSorter-v0", "one-step", "nll-lstm", 0, (("merge_touching", False),), 1, 40)
    m = run_cell(cell)["metrics"]
    assert m["e_mean"] == 0.0
    assert 0 < float(m["track_error_p25"]) <= float(m["track_error_p50"]) <= float(m["track_error_p75"])
    assert float(m["aleatoric_n"]) > 100
    # nll-lstm's calibration factor r > 1 widens the covariances: more inside every region
    assert float(m["reliability@0.50"]) > float(m["reliability_raw@0.50"])
    assert float(m["aleatoric_area_r"]) < 0  # the first predictions are the most uncertain


def test_act_before_observe_truth_is_refused():
    agent = make_agent("one-step", predictor="kf-cv")
    env = gym.make("BeltSorter-v0")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    with pytest.raises(RuntimeError, match="observe_truth"):
        agent.act(obs)
    env.close()
