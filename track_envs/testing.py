"""Public conformance checks for third-party environments, agents and predictors.

Each check raises ``AssertionError`` with a message naming what broke the contract of
docs/architecture.md (the observation, the report, ``info``, seeding; the Predictor and Agent
protocols). Use them in your own tests::

    from track_envs.testing import check_agent, check_predictor, check_tracking_env

    check_tracking_env(gym.make("MyScene-v0"))
    check_agent(MyTracker(), gym.make("BeltSorter-v0"))
    check_predictor(MyPredictor(), env.unwrapped.sensor_spec)

[`stream_digest`][track_envs.testing.stream_digest] pins what an env id emits, so that a change of its streams
is noticed (the rule: docs/architecture.md, "Streams are versioned").

Nothing here imports ``predictors`` or ``agents``: the objects under test are passed in.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from track_envs.contracts.report import empty_report, validate_report
from track_envs.values.types import Gaussian, SensorSpec

__all__ = [
    "PREDICTOR_METHODS",
    "STREAM_INFO_KEYS",
    "assert_equal_trees",
    "check_agent",
    "check_predictor",
    "check_tracking_env",
    "stream_digest",
]

#: The methods of the Predictor protocol (``predictors.base.Predictor``; not imported here).
PREDICTOR_METHODS = ("reset", "start", "predict", "update", "estimate")
#: The ``info`` entries [`stream_digest`][track_envs.testing.stream_digest] hashes by default (those an env
#: emits): the time,
#: the truth, the truth id(s) behind every detection row and the true sensor values of a drift.
STREAM_INFO_KEYS = ("t", "truth", "detection_ids", "detection_ids_merged", "sensor")


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, tuple | list):
        return isinstance(b, tuple | list) and len(a) == len(b) and all(map(_equal, a, b))
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def assert_equal_trees(a: Any, b: Any, where: str = "") -> None:
    """Assert nested dicts / tuples / lists of arrays and numbers are equal bit for bit.

    Raises:
        AssertionError: naming the first key path where they differ.
    """
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), f"{where or 'top'}: keys differ"
        for k in a:
            assert_equal_trees(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, tuple | list):
        assert isinstance(b, tuple | list) and len(a) == len(b), f"{where or 'top'}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_equal_trees(x, y, f"{where}[{i}]")
    else:
        np.testing.assert_array_equal(a, b, err_msg=where)


def check_tracking_env(env: gym.Env, steps: int = 20, seed: int = 0) -> None:
    """Check the tracking-env contract: spaces, padding, info shapes, detection ids, seeding, and
    the report contract (samples of the action space are valid reports; a report whose live rows
    repeat an id or hold a negative one is rejected with ``ValueError``).

    Args:
        env: The environment (wrapped or not).
        steps: Frames to step with empty reports.
        seed: Seed of the two compared rollouts.
    """
    base: Any = env.unwrapped
    spec = base.sensor_spec
    assert isinstance(spec, SensorSpec), (
        "env.unwrapped.sensor_spec must be a track_envs.values.types.SensorSpec"
    )
    report = empty_report(spec.max_tracks, tuple(base.position_shape))
    assert env.action_space.contains(report), "the empty report must lie in the action space"

    def rollout() -> list[Any]:
        obs, info = env.reset(seed=seed)
        frames = [(obs, info)]
        for _ in range(steps):
            obs, reward, terminated, truncated, info = env.step(report)
            assert np.isfinite(float(reward)), f"reward must be finite, got {reward!r}"
            frames.append((obs, info))
            if terminated or truncated:
                break
        return frames

    frames = rollout()
    for t, (obs, info) in enumerate(frames):
        assert env.observation_space.contains(obs), f"frame {t}: observation outside the observation space"
        mask = obs["mask"]
        real = int(mask.sum())
        assert np.all(mask[:real] == 1) and np.all(mask[real:] == 0), f"frame {t}: real rows must come first"
        assert np.all(obs["detections"][real:] == 0), f"frame {t}: padding rows must be zero"
        ids = info["detection_ids"]
        assert ids.shape == mask.shape and ids.dtype == np.int64, f"frame {t}: detection_ids shape/dtype"
        assert np.all(ids[mask == 0] == -1), f"frame {t}: padding rows must have detection id -1"
        truth = info["truth"]
        for key in ("ids", "positions", "visible"):
            assert key in truth, f"frame {t}: info['truth'] lacks {key!r}"
        known = set(truth["ids"][truth["ids"] >= 0].tolist())
        assert set(ids[ids >= 0].tolist()) <= known, (
            f"frame {t}: a detection's truth id is not in info['truth']"
        )
        assert isinstance(info["t"], float), f"frame {t}: info['t'] must be a float"
    again = rollout()
    assert len(frames) == len(again) and all(
        _equal(a[0], b[0]) and _equal(a[1]["detection_ids"], b[1]["detection_ids"])
        for a, b in zip(frames, again, strict=True)
    ), "the same seed must give bitwise equal rollouts"
    _check_report_contract(env, seed)


def _check_report_contract(env: gym.Env, seed: int) -> None:
    """Samples of the action space are valid reports; live rows with a repeated or negative id
    are rejected with ``ValueError``."""
    base: Any = env.unwrapped
    max_tracks = base.sensor_spec.max_tracks
    env.reset(seed=seed)
    env.action_space.seed(seed)
    for t in range(3):
        sample = env.action_space.sample()
        try:
            _, reward, terminated, truncated, _ = env.step(sample)
        except ValueError as exc:
            raise AssertionError(
                f"step {t}: a sample of the action space must be a valid report ({exc})"
            ) from exc
        assert np.isfinite(float(reward)), f"reward of a sampled report must be finite, got {reward!r}"
        if terminated or truncated:
            env.reset(seed=seed)
    if max_tracks < 2:
        return
    for what, ids in (("a repeated id", [7, 7]), ("a negative id", [-1, 3])):
        report = empty_report(max_tracks, tuple(base.position_shape))
        report["mask"][:2] = 1
        report["ids"][:2] = ids
        try:
            env.step(report)
        except ValueError:
            continue
        raise AssertionError(f"step must reject a report whose live rows hold {what} (ValueError)")


def check_agent(agent: Any, env: gym.Env, steps: int = 20, seed: int = 0) -> None:
    """Check an agent on an environment: valid reports (unique track ids, in the action space,
    accepted by [`validate_report`][track_envs.contracts.validate_report]), detection rows, determinism under
    a seed, and that it rejects (``ValueError``) observations that break the contract: mask values
    other than 0/1, a float mask, NaN in a masked-in row, wrong shapes, a non-mapping observation.

    Raises:
        AssertionError: naming what broke the contract (a malformed report included).
    """
    missing = [m for m in ("reset", "act") if not callable(getattr(agent, m, None))]
    assert not missing, (
        f"an agent must have the methods reset(spec, *, seed) and act(obs); it lacks {missing}"
    )
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]

    def rollout() -> list[dict[str, Any]]:
        obs, _ = env.reset(seed=seed)
        agent.reset(spec, seed=seed)
        reports = []
        for _ in range(steps):
            report = agent.act(obs)
            _assert_unique_ids(report)
            assert env.action_space.contains(report), "the report must lie in the env's action space"
            try:
                validate_report(report, spec.max_tracks, tuple(env.unwrapped.position_shape), obs["mask"])  # type: ignore[attr-defined]
            except ValueError as exc:
                raise AssertionError(f"the agent's report is malformed: {exc}") from exc
            used = report["detection"][report["mask"] == 1]
            assert np.all((used == -1) | (obs["mask"][np.maximum(used, 0)] == 1)), (
                "a report's detection rows must point at masked-in detections or be -1"
            )
            reports.append(report)
            obs, reward, terminated, truncated, _ = env.step(report)
            assert np.isfinite(float(reward)), f"reward must be finite, got {reward!r}"
            if terminated or truncated:
                break
        return reports

    first, second = rollout(), rollout()
    assert len(first) == len(second) and all(_equal(a, b) for a, b in zip(first, second, strict=True)), (
        "an agent reset with the same seed must report the same tracks"
    )
    _check_rejects_bad_observations(agent, env, seed)


def _assert_unique_ids(report: Any) -> None:
    """The live rows (mask 1) of ``report`` carry distinct ids; checked before the action space
    and [`validate_report`][track_envs.contracts.validate_report] (which would refuse the report without
    naming the ids)."""
    try:
        ids = np.asarray(report["ids"])[np.asarray(report["mask"]) == 1]
    except (KeyError, IndexError, TypeError):
        return  # a report of another layout: the action space and validate_report name it
    values, counts = np.unique(ids, return_counts=True)
    repeated = values[counts > 1]
    assert len(repeated) == 0, f"track ids must be unique within a report; repeated: {repeated[:10].tolist()}"


def _bad_observations(obs: dict[str, Any]) -> dict[str, Any]:
    """Observations that break the contract, each derived from the real ``obs``, by what is wrong."""
    mask, detections = obs["mask"], obs["detections"]
    bad: dict[str, Any] = {}
    for value in (2, -1):
        wrong = mask.copy()
        wrong[-1] = value
        bad[f"a mask value of {value}"] = {**obs, "mask": wrong}
    bad["a float mask"] = {**obs, "mask": mask.astype(np.float64)}
    live = np.flatnonzero(mask == 1)
    if len(live):
        nan = detections.copy()
        nan[live[0]] = np.nan
        bad["NaN in a masked-in detection row"] = {**obs, "detections": nan}
    bad["detections with a row too few"] = {**obs, "detections": detections[:-1], "mask": mask[:-1]}
    bad["a tuple instead of a mapping"] = (detections, mask)
    return bad


def _check_rejects_bad_observations(agent: Any, env: gym.Env, seed: int) -> None:
    """The agent refuses (``ValueError``) observations that break the contract."""
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    obs, _ = env.reset(seed=seed)
    for what, bad in _bad_observations(obs).items():
        agent.reset(spec, seed=seed)
        try:
            agent.act(bad)
        except ValueError:
            continue
        raise AssertionError(f"the agent must reject an observation with {what} (raise ValueError)")


def check_predictor(predictor: Any, spec: SensorSpec, n: int = 5, seed: int = 0) -> None:
    """Check a predictor against the Predictor protocol: shapes, coasting, take/concat, empty batches."""
    missing = [m for m in PREDICTOR_METHODS if not callable(getattr(predictor, m, None))]
    assert not missing, f"a predictor must have the methods {list(PREDICTOR_METHODS)}; it lacks {missing}"
    rng = np.random.default_rng(seed)
    predictor.reset(spec)
    d = spec.dim
    lo, size = np.asarray(spec.region_low), spec.region_size
    z = lo + rng.random((n, d)) * size
    state = predictor.start(z)
    assert len(state) == n, f"start(z) with {n} rows must give a state of {n} tracks, got {len(state)}"
    state, prediction = predictor.predict(state)
    assert isinstance(prediction, Gaussian), "predict must return (state, track_envs.values.types.Gaussian)"
    assert prediction.mean.shape == (n, d) and prediction.cov.shape == (n, d, d), "prediction shapes"
    assert np.all(np.linalg.eigvalsh(prediction.cov) > 0), "predicted covariances must be positive definite"
    seen = np.arange(n) % 2 == 0
    z_new = np.where(seen[:, None], z + 0.01 * size, np.nan)
    updated = predictor.update(state, z_new, seen)
    estimate = predictor.estimate(updated)
    assert estimate.mean.shape == (n, d) and np.all(np.isfinite(estimate.mean)), "estimate of every track"
    coasted = predictor.estimate(state)
    assert np.array_equal(estimate.mean[~seen], coasted.mean[~seen]), "rows not seen must coast unchanged"
    both = type(updated).concat([updated.take(np.arange(2)), updated.take(np.arange(2, n))])
    assert _equal(predictor.estimate(both).mean, estimate.mean), "take + concat must keep every track"
    empty = updated.take(np.zeros(n, dtype=bool))
    _, empty_prediction = predictor.predict(empty)
    assert empty_prediction.mean.shape == (0, d), "an empty batch must predict an empty Gaussian"


def _hash_tree(h: Any, value: Any) -> None:
    """Feed ``value`` into the hash ``h`` canonically: dict keys sorted, every array (and number)
    as its dtype, shape and C-order bytes, each item tagged by its kind and length."""
    if isinstance(value, dict):
        h.update(b"d%d;" % len(value))
        for key in sorted(value, key=str):
            _hash_tree(h, str(key))
            _hash_tree(h, value[key])
    elif isinstance(value, tuple | list):
        h.update(b"l%d;" % len(value))
        for item in value:
            _hash_tree(h, item)
    elif isinstance(value, str):
        data = value.encode()
        h.update(b"s%d;" % len(data) + data)
    elif value is None:
        h.update(b"n;")
    else:
        arr = np.ascontiguousarray(np.asarray(value))
        if arr.dtype == object:
            raise TypeError(f"stream_digest hashes arrays, numbers, strings and containers, got {value!r}")
        h.update(b"a%s;%s;" % (arr.dtype.str.encode(), str(arr.shape).encode()))
        h.update(arr.tobytes())


def stream_digest(
    env: gym.Env,
    seed: int,
    steps: int = 200,
    action: Callable[[Any], Any] | None = None,
    info_keys: Sequence[str] = STREAM_INFO_KEYS,
) -> str:
    """The sha256 digest of an episode's stream: what ``env`` emits for ``seed``.

    The episode starts with ``env.reset(seed=seed)`` and runs ``steps`` steps, fewer when it
    ends earlier. Hashed, in order: the reset's observation and ``info``, then for every step
    its observation, reward, ``terminated``, ``truncated`` and ``info``; of each ``info`` only
    the entries of ``info_keys`` it holds (by default
    `STREAM_INFO_KEYS`: the truth side). Arrays are hashed with their
    dtype and shape, dicts with their keys sorted, so the digest changes exactly when a value, dtype or shape
    of the stream does.

    Args:
        env: The environment (wrapped or not).
        seed: The reset seed.
        steps: Steps after the reset.
        action: The action of each step as a function of the last observation; by default the
            empty report of a tracking env (``env.unwrapped`` has ``sensor_spec`` and
            ``position_shape``), which makes the reward a function of the truth alone.
        info_keys: The ``info`` entries hashed.

    Returns:
        The hex digest (64 characters).
    """
    if action is None:
        base: Any = env.unwrapped
        report = empty_report(base.sensor_spec.max_tracks, tuple(base.position_shape))
        action = lambda obs: report  # noqa: E731
    h = hashlib.sha256()

    def feed(obs: Any, info: dict[str, Any], *rest: Any) -> None:
        _hash_tree(h, [obs, *rest, {k: info[k] for k in info_keys if k in info}])

    obs, info = env.reset(seed=seed)
    feed(obs, info)
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(action(obs))
        feed(obs, info, float(reward), bool(terminated), bool(truncated))
        if terminated or truncated:
            break
    return h.hexdigest()
