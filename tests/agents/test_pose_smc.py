"""The SMC pose tracker (Okada et al. 2020, Algorithm 1): reduction, determinism, elites, arguments."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import agent_applies_to, make_agent
from agents.pose.smc import PoseSmcAgent
from agents.pose.tracker import PoseTracker, detection_areas
from predictors.pose import centroid_fill
from predictors.pose_lstm.predictor import PosePredictor, window_features
from predictors.pose_lstm.training import pose_windows_from_env, to_model_file, train_pose_model
from predictors.training.loop import TrainConfig
from track_envs.metrics.keypoints import pairwise_oks

EASY = {"num_people": 3, "occlusion": False, "num_occluders": 0, "vanish_rate": 0.0, "clutter_rate": 0.0,
        "swap_prob": 0.0}  # fmt: skip


@pytest.fixture(scope="module")
def model():
    data = pose_windows_from_env(episodes=1, steps=80, window=10, seed=500)
    train, validation, _ = data.split(0)
    config = TrainConfig(epochs=2, lr=1e-3, batch_size=30, decay_every=1000, seed=0)
    net, _ = train_pose_model(train, validation, config, progress=False)
    return to_model_file(net, 1 / 72, metrics={"fixed_sigma": [0.5, 0.5]})


def rollout(agent, seed: int, steps: int = 40, **env_kwargs):
    env = gym.make("KeypointWalkers-v0", **env_kwargs)
    obs, _ = env.reset(seed=seed)
    agent.reset(env.unwrapped.sensor_spec, seed=seed)
    reports = []
    for _ in range(steps):
        report = agent.act(obs)
        reports.append(report)
        obs, *_ = env.step(report)
    return reports


class WindowMean:
    """A single-hypothesis reference: the predictor's mean from one queue, no particles at all."""

    def __init__(self, predictor, L):
        self.p, self.L = predictor, L

    def reset(self, spec, rng):
        self.scale = self.p.scale_for(spec.region_high[1] - spec.region_low[1])
        self.own = np.zeros((0, 17, self.L, 3), np.float32)
        self.obs = np.zeros((0, 17, self.L, 3), np.float32)
        self.est = np.zeros((0, 17, 2))

    def predict(self):
        inputs, anchor, self.has = window_features(self.own.reshape(-1, self.L, 3), self.scale)
        mu, _ = self.p.distribution(inputs, None, epistemic=False)
        self.z = (anchor + self.scale * mu).reshape(-1, 17, 2) * self.has.reshape(-1, 17, 1)
        self.has = self.has.reshape(-1, 17)

    def score(self, xy, found, area, floor=0.0):
        return pairwise_oks(self.z, xy, found, area, a_valid=self.has)

    def update(self, ti, di, xy, found):
        push = lambda q, e: np.concatenate([q[..., 1:, :], e[..., None, :]], axis=-2)  # noqa: E731
        obs_entry = np.zeros((len(self.own), 17, 3), np.float32)
        obs_entry[ti] = np.concatenate([xy[di] * found[di][..., None], found[di][..., None]], axis=-1)
        self.own = push(self.own, np.concatenate([self.z, self.has[..., None]], axis=-1).astype(np.float32))
        self.obs = push(self.obs, obs_entry)
        self.own[ti] = self.obs[ti]  # α = 0: the observation history is always selected
        est = centroid_fill(self.z, self.has)
        est[ti] = centroid_fill(np.where(found[di][..., None], xy[di], self.z[ti]), found[di] | self.has[ti])
        self.est = est

    def birth(self, xy, found):
        q = np.zeros((len(xy), 17, self.L, 3), np.float32)
        q[..., -1, :2], q[..., -1, 2] = xy * found[..., None], found
        self.own, self.obs = np.concatenate([self.own, q]), np.concatenate([self.obs, q])
        self.est = np.concatenate([self.est, centroid_fill(xy, found)])

    def keep(self, alive):
        self.own, self.obs, self.est = self.own[alive], self.obs[alive], self.est[alive]

    def poses(self):
        return self.est


def test_one_particle_no_uncertainty_and_alpha_zero_is_a_single_hypothesis_tracker(model):
    smc = PoseSmcAgent(model, particles=1, alpha=0.0, epistemic=False, aleatoric=False, fixed_sigma=0.0)
    ref = PoseTracker(WindowMean(PosePredictor(model), 10), max_active=100)
    for a, b in zip(rollout(smc, 3), rollout(ref, 3), strict=True):
        np.testing.assert_array_equal(a["ids"], b["ids"])
        np.testing.assert_array_equal(a["detection"], b["detection"])
        np.testing.assert_allclose(a["positions"], b["positions"], atol=1e-3)


def test_the_same_seed_gives_the_same_tracks_and_another_seed_other_particles(model):
    a = rollout(PoseSmcAgent(model, particles=20), 1, steps=15)
    b = rollout(PoseSmcAgent(model, particles=20), 1, steps=15)
    for x, y in zip(a, b, strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    agent = PoseSmcAgent(model, particles=20)
    env = gym.make("KeypointWalkers-v0")
    obs, _ = env.reset(seed=1)
    particles = []
    for seed in (0, 1):
        agent.reset(env.unwrapped.sensor_spec, seed=seed)
        agent.act(obs)
        agent.act(obs)
        particles.append(agent.motion.pred.copy())
    assert particles[0].shape == particles[1].shape and not np.allclose(particles[0], particles[1])


@pytest.mark.parametrize("recurrence", ["window", "carried"])
def test_an_easy_scene_keeps_its_identities(model, recurrence):
    agent = PoseSmcAgent(model, particles=30, recurrence=recurrence)
    reports = rollout(agent, 0, steps=60, **EASY)
    ids = {int(i) for r in reports for i in r["ids"][r["mask"] == 1]}
    assert len(ids) <= 5  # three people (and at most a couple arriving)


def test_the_matching_score_is_the_mean_oks_of_the_elites(model):
    agent = PoseSmcAgent(model, particles=20, elite=0.25)
    env = gym.make("KeypointWalkers-v0", **EASY)
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    agent.act(obs)
    obs, *_ = env.step(agent.act(obs))
    m = agent.motion
    m.predict()
    rows = np.flatnonzero(obs["mask"] == 1)
    xy, found = obs["detections"][rows, :, :2].astype(float), obs["detections"][rows, :, 2] > 0
    score = m.score(xy, found, detection_areas(xy, found, 0.25))
    oks = pairwise_oks(m.pred.reshape(-1, 17, 2), xy, found, detection_areas(xy, found, 0.25),
                       a_valid=m.has.reshape(-1, 17)).reshape(len(m), 20, -1)  # fmt: skip
    np.testing.assert_allclose(score, np.sort(oks, axis=1)[:, -5:].mean(axis=1))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"particles": 0}, "particles"), ({"alpha": 1.5}, "alpha"), ({"alpha": -0.1}, "alpha"),
     ({"elite": 0.0}, "elite"), ({"elite": 1.2}, "elite"), ({"window": 0}, "window"),
     ({"recurrence": "lstm"}, "recurrence"), ({"fixed_sigma": -1.0}, "fixed_sigma"),
     ({"max_filters": 0}, "max_filters")],
)  # fmt: skip
def test_bad_arguments_are_named(model, kwargs, name):
    with pytest.raises(ValueError, match=name):
        PoseSmcAgent(model, **kwargs)


def test_pose_smc_is_registered_for_pose_envs_only():
    assert agent_applies_to("pose-smc", (17, 2)) and not agent_applies_to("pose-smc", (2,))
    assert isinstance(make_agent("pose-smc", particles=2), PoseSmcAgent)


def test_sharing_prefixes_gives_the_bits_of_rerunning_every_window(model):
    """The default (the LSTM once per distinct prefix of the distinct queues, the FC block's first
    layer once per distinct queue) reports exactly what re-running every particle's window does."""
    shared = rollout(PoseSmcAgent(model, particles=40), 2, steps=25)
    rerun = rollout(PoseSmcAgent(model, particles=40, share_windows=False), 2, steps=25)
    for a, b in zip(shared, rerun, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_the_reports_do_not_depend_on_the_threads(model):
    import torch

    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = rollout(PoseSmcAgent(model, particles=60), 3, steps=12)
        torch.set_num_threads(2)
        two = rollout(PoseSmcAgent(model, particles=60), 3, steps=12)
    finally:
        torch.set_num_threads(before)
    for a, b in zip(one, two, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_the_shipped_tracker_reports_what_the_straightforward_predictor_reports():
    """Pinned: the reports of re-running every window with the shipped network the straightforward
    way (torch's ``nn.LSTM`` over every particle's window and the network's FC head, the tracker's
    own draws: dropout decisions as 16-bit fields; ``TorchReferencePredictor`` of
    ``benchmarks/bench_pose_smc.py`` with ``share_windows=False``; 6 people, P = 100, seeds 0 and 1,
    30 frames). The default gives every id and every position to 1e-4 px (3.1e-5 when pinned): the
    LSTM and the FC head sum their products in another order than torch's, which moves a float32
    position by about one ulp."""
    pinned = np.load(Path(__file__).parent / "data" / "pose_smc_window_reference.npz")
    for seed in (0, 1):
        reports = rollout(PoseSmcAgent(particles=100), seed, steps=30, num_people=6, initial_people=6)
        ids = np.array([r["ids"] for r in reports])
        positions = np.array([r["positions"] for r in reports])
        np.testing.assert_array_equal(ids, pinned[f"reference_ids_{seed}"])
        np.testing.assert_allclose(positions, pinned[f"reference_positions_{seed}"], rtol=0, atol=1e-4)


def test_a_floor_scores_only_the_pairs_that_can_reach_it(model):
    """``score(..., floor)`` skips pairs whose OKS bound is below the floor: every pair at or above
    it scores exactly as without a floor, every other pair scores below it (0)."""
    agent = PoseSmcAgent(model, particles=50)
    env = gym.make("KeypointWalkers-v0", num_people=6, initial_people=6)
    obs, _ = env.reset(seed=4)
    agent.reset(env.unwrapped.sensor_spec, seed=4)
    for _ in range(6):
        obs, *_ = env.step(agent.act(obs))
    m = agent.motion
    m.predict()
    rows = np.flatnonzero(obs["mask"] == 1)
    xy, found = obs["detections"][rows, :, :2].astype(float), obs["detections"][rows, :, 2] > 0
    area = detection_areas(xy, found, 0.25)
    full = m.score(xy, found, area)
    full_elite = m._elite.copy()
    floored = m.score(xy, found, area, floor=0.3)
    reach = full >= 0.3
    assert reach.any() and (~reach).any()
    np.testing.assert_array_equal(floored[reach], full[reach])
    ki, di = np.nonzero(reach)
    np.testing.assert_array_equal(m._elite[ki, :, di], full_elite[ki, :, di])
    assert np.all(floored[~reach] < 0.3)
    assert np.count_nonzero(floored) < floored.size  # pairs were skipped


def test_a_shipped_model_is_named_by_its_name():
    from predictors.pose_lstm.motion import DEFAULT_MODEL, pose_model_path
    from predictors.training.model_file import ModelFileError

    assert pose_model_path("pose-lstm-walkers") == DEFAULT_MODEL == pose_model_path(None)
    assert str(pose_model_path("models/mine")) == "models/mine"  # a path stays a path
    agent = PoseSmcAgent("pose-lstm-walkers", particles=2)
    assert agent.motion.predictor.model.kind == "pose-lstm"
    with pytest.raises(ModelFileError, match=r"no-such-model\.json does not exist"):
        PoseSmcAgent("no-such-model", particles=2)


def test_the_one_pass_queue_update_is_push_then_resample_and_select():
    from predictors.pose_lstm.motion import advance_queues, push_queues, select_queues

    rng = np.random.default_rng(3)
    n, P, L = 4, 6, 5
    queue = rng.normal(0, 100, (n, P, 17, L, 3)).astype(np.float32)
    pred, has = rng.normal(0, 100, (n, P, 17, 2)), rng.random((n, P, 17)) < 0.8
    obs = rng.normal(0, 100, (n, 17, L, 3)).astype(np.float32)
    ti = np.array([2, 0])
    idx, own = rng.integers(0, P, (2, P)), rng.random((2, P)) < 0.5
    want = queue.copy()
    push_queues(want, pred, has)
    select_queues(want, obs, ti, idx, own)
    sel = np.full(n, -1)
    sel[ti] = np.arange(2)
    got = np.empty_like(queue)
    advance_queues(queue, got, pred, has, obs, sel, idx, own)
    np.testing.assert_array_equal(got, want)
