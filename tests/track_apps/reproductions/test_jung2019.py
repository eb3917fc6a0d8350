"""The batched experiments of Jung et al. (2019) (track_apps/reproductions/jung2019.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_apps.reproductions import jung2019 as exp
from track_envs.envs.single_target import to_world


def test_a_rotated_scene_is_the_rotation_of_the_unrotated_one_under_the_same_seed():
    rot = exp.exp1_rotation(3, models=("brownian",), periods=2.0, seed=4)
    for key in ("truth", "detections"):
        np.testing.assert_allclose(
            getattr(rot[45.0], key), to_world(getattr(rot[0.0], key), 45.0, (0.0, 0.0)), atol=1e-12
        )


def test_the_lstm_filter_is_rotation_invariant():
    # (r, s) does not change under a rotation; only the filters' own draws are not rotated with the scene
    # (over 24 runs of 8 periods the two errors agree within 3.5% for seeds 0-7)
    rot = exp.exp1_rotation(24, models=("lstm",), periods=8.0, seed=0)
    e0, e45 = (float(np.nanmean(rot[r].filters["lstm"].mean_error)) for r in (0.0, 45.0))
    assert abs(e45 / e0 - 1) < 0.10, (e0, e45)


def test_each_filter_of_a_batch_is_the_filter_run_alone():
    kwargs = dict(truth=exp.sine(1.0), p_detect=[0.5, 0.9], sigma_p=[0.5, 1.0], n_particles=30, seed=3)
    both = exp.run_batch(models=("brownian", "cv"), **kwargs)
    alone = exp.run_batch(models=("cv",), **kwargs)
    np.testing.assert_array_equal(both.filters["cv"].mean_error, alone.filters["cv"].mean_error)
    assert not np.array_equal(both.filters["cv"].mean_error, both.filters["brownian"].mean_error)


def test_traced_runs_record_estimates_truth_and_the_particle_spread():
    batch = exp.run_batch(exp.sine(1.0), 1.0, 0.5, 40, models=("brownian",), n_runs=3, trace=[1], seed=0)
    f = batch.filters["brownian"]
    assert batch.truth.shape == batch.detections.shape == f.estimates.shape == (1, 32, 2)
    assert np.isfinite(batch.detections).all()  # p_d = 1
    assert f.mean_error.shape == (3,) and f.error_over_time.shape == (32,)
    assert np.all(f.spread[0] > 0) and np.all(f.spread_std[0] > 0)
    # one particle: its distance to the truth is the estimate's error, and it has no spread
    one = exp.run_batch(exp.sine(1.0), 1.0, 0.5, 1, models=("brownian",), n_runs=2, trace=[0, 1], seed=0)
    g = one.filters["brownian"]
    np.testing.assert_allclose(g.spread, np.linalg.norm(g.estimates - one.truth, axis=2), atol=1e-12)
    np.testing.assert_allclose(g.spread_std, 0.0, atol=1e-12)
    np.testing.assert_allclose(g.mean_error, g.spread.mean(axis=1))
    np.testing.assert_allclose(g.particle_error, g.mean_error)
    assert np.all(f.particle_error >= f.mean_error)  # Jensen: Σ w |x⁽ⁱ⁾ − x| >= |Σ w x⁽ⁱ⁾ − x| per frame


def test_piecewise_scenes_are_the_env_trajectories():
    scenes = exp.piecewise_scenes(2, 2.0, seed=7)
    for r in range(2):
        env = gym.make("PiecewiseTarget-v0", periods=2.0)
        env.reset(seed=7 + r)
        np.testing.assert_allclose(scenes[r], env.unwrapped.trajectory)


def test_after_turns_marks_the_frames_after_each_change_of_heading():
    steps = np.array([[1.0, 0.0]] * 4 + [[0.0, 1.0]] * 5 + [[1.0, 0.0]] * 3)
    scene = np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])[None]
    mask = exp.after_turns(scene, window=3)
    assert np.flatnonzero(mask[0]).tolist() == [5, 6, 7, 10, 11, 12]
    batch = exp.run_batch(scene, 1.0, 0.5, 20, models=("brownian",), per_frame=True, seed=0)
    errors = batch.filters["brownian"].errors
    assert errors is not None and errors.shape == (1, 13)
    np.testing.assert_allclose(np.nanmean(errors, axis=1), batch.filters["brownian"].mean_error)


def test_lost_and_kept_and_gain():
    mean_kept, lost = exp.lost_and_kept(np.array([[1.0, 3.0, 6.0, np.nan], [7.0, 8.0, 9.0, 10.0]]))
    np.testing.assert_allclose(mean_kept[0], 2.0)
    assert np.isnan(mean_kept[1])
    np.testing.assert_allclose(lost, [50.0, 100.0])
    np.testing.assert_allclose(exp.gain_percent([2.0, 1.0], [0.5, 1.5]), [75.0, -50.0])
    # paired runs: d = (1, 2), mean 1.5 against a Brownian mean of 3; the NaN run is left out
    gain, se = exp.paired_gain([[2.0, 4.0, np.nan]], [[1.0, 2.0, 0.5]])
    np.testing.assert_allclose(gain, [50.0])
    np.testing.assert_allclose(se, [100.0 * np.sqrt(0.5) / np.sqrt(2.0) / 3.0])


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="truth must have shape"):
        exp.run_batch(np.zeros((5, 3)), 0.5, 0.5, 10)
    with pytest.raises(ValueError, match="p_detect must be finite"):
        exp.run_batch(exp.sine(1.0), [np.nan], 0.5, 10)
    with pytest.raises(ValueError, match="unknown model"):
        exp.run_batch(exp.sine(1.0), 0.5, 0.5, 10, models=("kalman",))
