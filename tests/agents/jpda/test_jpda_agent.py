"""The jpda tracker: sensor model from the spec, the PDA update, every Gaussian predictor,
determinism, bad arguments, and belt behaviour against gnn."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from agents.jpda.agent import MIN_CLUTTER_RATE, JpdaAgent
from track_envs.metrics.belt import AssociationErrors
from track_envs.values.types import SensorSpec

SPEC = SensorSpec(
    dt=0.01, dim=2, noise_std=1e-3, p_detect=0.9, clutter_rate=5.0,
    region_low=(0.0, 0.0), region_high=(2.0, 0.5), max_detections=16, max_tracks=16,
)  # fmt: skip


def observation(points: np.ndarray, rows: int = 16) -> dict[str, np.ndarray]:
    det = np.zeros((rows, 2), np.float32)
    mask = np.zeros(rows, np.int8)
    det[: len(points)], mask[: len(points)] = points, 1
    return {"detections": det, "mask": mask}


def run(env, agent, frames, seed=0):
    metric = AssociationErrors()
    obs, info = env.reset(seed=seed)
    agent.reset(env.unwrapped.sensor_spec, seed=seed)
    reports = []
    for _ in range(frames):
        report = agent.act(obs)
        reports.append(report)
        metric.update(info["truth"], info["detection_ids"], report)
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    return metric.compute(), reports


def test_detection_probability_and_clutter_density_come_from_the_sensor_spec():
    agent = make_agent("jpda")
    agent.reset(SPEC)
    assert agent.p_detect == 0.9
    assert agent.clutter_density == pytest.approx(5.0 / (2.0 * 0.5))
    quiet = SensorSpec(**{**SPEC.__dict__, "clutter_rate": 0.0, "p_detect": 1.0})
    agent.reset(quiet)
    assert agent.clutter_density == pytest.approx(MIN_CLUTTER_RATE / 1.0) and agent.p_detect == 1.0
    fixed = make_agent("jpda", p_detect=0.5, clutter_density=3.0)
    fixed.reset(SPEC)
    assert (fixed.p_detect, fixed.clutter_density) == (0.5, 3.0)


def test_a_track_between_two_detections_takes_their_weighted_mean():
    """One established track, two detections in its gate, clutter declared: the PDA update moves
    it by the β-weighted innovation (not onto either detection), and its covariance grows by the
    spread of the hypotheses (the Kalman oracle is in tests/predictors/test_kalman_mixture.py)."""
    agent = make_agent("jpda", predictor="kf-cv", velocity_prior=None, recovery_inflation=1.0)
    agent.reset(SPEC)
    x = np.array([[1.0, 0.25]])
    for _ in range(6):
        agent.act(observation(x))
    before = agent.track_covariances()[0]
    z = x + np.array([[0.0, 0.0015], [0.0, -0.0015]])
    report = agent.act(observation(z))
    live = report["mask"] == 1
    pos, ids = report["positions"][live], report["ids"][live]
    assert abs(pos[ids == ids.min()][0, 1] - 0.25) < 2e-4  # the mean stays between them
    assert len(pos) == 2  # the detection its most probable hypothesis left starts a track
    assert 0.4 < agent.last_p_seen[0] <= 1.0
    after = agent.track_covariances()[0]
    assert after[1, 1] > 0.5 * before[1, 1]  # the spread term keeps the lateral variance up


@pytest.mark.parametrize("predictor", ["kf-cv", "kf-ca", "random-walk", "lstm", "nll-lstm", "mc-lstm"])
def test_every_gaussian_predictor_tracks_the_belt_and_is_deterministic(predictor):
    env = gym.make("BeltSorter-v0", noise_std=1e-4, merge_touching=False)
    result, reports = run(env, make_agent("jpda", predictor=predictor), 60, seed=3)
    _, again = run(env, make_agent("jpda", predictor=predictor), 60, seed=3)
    for a, b in zip(reports, again, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert result["n_particles"] > 100
    if predictor != "random-walk":
        assert result["e2"] < 0.1 and result["e1"] < 0.1


def test_on_the_belt_without_merges_jpda_keeps_identities_as_well_as_gnn():
    # measured (seed 0, 300 frames, one detection per particle, 0.1 mm): e_mean gnn 0.00036-class
    env = gym.make("BeltSorter-v0", noise_std=1e-4, merge_touching=False)
    jpda, _ = run(env, make_agent("jpda", predictor="kf-ca"), 300)
    gnn, _ = run(env, make_agent("gnn", predictor="kf-ca"), 300)
    assert jpda["e_mean"] <= gnn["e_mean"] + 0.002


def test_clusters_above_max_exact_fall_back_and_are_counted():
    """Without the coalescence guard a cluster above max_exact goes to loopy belief propagation;
    with it (default) its tracks take gnn's assignment and no marginals are computed for them
    (random-walk's gates span the belt: 0.2 s per frame of loopy BP otherwise)."""
    pair = np.array([[1.0, 0.25], [1.0, 0.2504]])
    for guard, approximated in ((False, True), (True, False)):
        agent = make_agent(
            "jpda", predictor="kf-cv", max_exact=1, velocity_prior=None, coalescence_guard=guard
        )
        agent.reset(SPEC)
        for _ in range(5):
            report = agent.act(observation(pair))
        assert (agent.approximate_tracks > 0) == approximated
        assert (report["mask"] == 1).sum() == 2


def test_warm_up_leaves_the_tracker_untouched():
    agent = make_agent("jpda", predictor="kf-ca")
    agent.reset(SPEC)
    agent.act(observation(np.array([[1.0, 0.25]])))
    ids = agent._ids.copy()
    agent.warm_up()
    assert agent._ids.tolist() == ids.tolist() and agent.n_tracks == 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"p_detect": 1.5}, "p_detect must be None or a probability in \\(0, 1\\], got 1.5"),
        ({"p_detect": 0.0}, "p_detect must be None or a probability"),
        ({"clutter_density": -1.0}, "clutter_density must be a finite number > 0, got -1.0"),
        ({"min_clutter_rate": 0}, "min_clutter_rate must be a finite number > 0, got 0"),
        ({"merge_model": "yes"}, "merge_model must be True or False, got 'yes'"),
        ({"merge_extent": 0.0}, "merge_extent must be a finite number > 0"),
        ({"merge_area_std": -0.1}, "merge_area_std must be a finite number >= 0"),
        ({"merge_odds": float("inf")}, "merge_odds must be a finite number > 0"),
        ({"max_exact": 0}, "max_exact must be an integer >= 1, got 0"),
        ({"coalescence_guard": 1}, "coalescence_guard must be True or False, got 1"),
        ({"blob_extent": 0.004}, "jpda has no argument 'blob_extent'"),
        ({"assignment": "greedy"}, "jpda has no argument 'assignment'"),
        ({"p_gate": 2.0}, "p_gate must be a probability"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        JpdaAgent(**kwargs)


def test_the_coalescence_guard_keeps_wide_gates_apart():
    """random-walk's gates span the neighbouring particles: without the guard every track's
    mixture is pulled between particles and identities dissolve; with it jpda stays near gnn."""
    env = gym.make("BeltSorter-v0", noise_std=1e-4, merge_touching=False)
    gnn, _ = run(env, make_agent("gnn", predictor="random-walk"), 100)
    jpda, _ = run(env, make_agent("jpda", predictor="random-walk"), 100)
    loose, _ = run(env, make_agent("jpda", predictor="random-walk", coalescence_guard=False), 100)
    assert jpda["e_mean"] <= gnn["e_mean"] + 0.05
    assert loose["e_mean"] >= jpda["e_mean"] + 0.15, (loose, jpda, gnn)


def test_loopy_bp_product_runs_on_one_blas_thread(monkeypatch):
    """The LBP branch's (n × m) @ (m × 2) product is a frame's small product: one BLAS thread
    (track_envs.infra.blas_threads), whatever the library's own count."""
    import contextlib

    from threadpoolctl import threadpool_limits

    from agents.jpda import associator
    from track_envs.infra.blas_threads import blas_info

    inside: list[set[int]] = []
    pinned = associator.frame_blas

    @contextlib.contextmanager
    def recording():
        with pinned():
            inside.append({int(i["num_threads"]) for i in blas_info()})
            yield

    monkeypatch.setattr(associator, "frame_blas", recording)
    pair = np.array([[1.0, 0.25], [1.0, 0.2504]])
    agent = make_agent("jpda", predictor="kf-cv", max_exact=1, velocity_prior=None, coalescence_guard=False)
    agent.reset(SPEC)
    blas_info()
    with threadpool_limits(2, user_api="blas"):
        for _ in range(5):
            agent.act(observation(pair))
    assert agent.approximate_tracks > 0 and inside and all(s == {1} for s in inside)
