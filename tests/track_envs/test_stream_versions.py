"""Streams are versioned: what every registered env id emits is pinned by a digest.

For every id (the ids of ``track_envs`` and GateTuning-v0 of ``track_apps.tuning``) and two seeds,
:func:`track_envs.testing.stream_digest` hashes the first :data:`STEPS` steps (fewer where the
episode ends earlier: GateTuning-v0 ends after 100 steps of 10 tracked frames each):
observations, rewards, ``terminated`` / ``truncated`` and the truth side of ``info``. The
digests are recorded in ``data/stream_digests.json``. A change of what an id emits fails here
and needs a new version id (``ID-v1``) while the old id keeps its streams, as Gymnasium's
``-vN`` rule asks.

The action is the simplest deterministic one: the empty report for the tracking envs (so the
reward is a function of the truth alone) and the zero action (the middle of every knob's range)
for GateTuning-v0.

To record the digests after adding an id (never to hide a change of an existing one)::

    TRACK_ENVS_UPDATE_DIGESTS=1 python -m pytest tests/track_envs/test_stream_versions.py
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_apps.tuning
import track_envs
from track_envs.testing import stream_digest

DIGESTS = Path(__file__).parent / "data" / "stream_digests.json"
UPDATE = os.environ.get("TRACK_ENVS_UPDATE_DIGESTS") == "1"
SEEDS = (0, 1)
STEPS = 200
#: ``info`` entries hashed where they differ from the default (GateTuning-v0 has no truth rows:
#: its truth side is the error count and the true sensor values).
INFO_KEYS = {track_apps.tuning.ENV_ID: ("knobs", "association_errors", "frames", "sensor")}
ENV_IDS = (*track_envs.ENV_IDS, track_apps.tuning.ENV_ID)


def digest(env_id: str, seed: int) -> str:
    env = gym.make(env_id)
    kwargs = {}
    if env_id in INFO_KEYS:
        kwargs["info_keys"] = INFO_KEYS[env_id]
    if not isinstance(env.action_space, gym.spaces.Dict):
        zero = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)
        kwargs["action"] = lambda obs: zero
    try:
        return stream_digest(env, seed, STEPS, **kwargs)
    finally:
        env.close()


def record(key: str, value: str) -> None:
    recorded = json.loads(DIGESTS.read_text()) if DIGESTS.exists() else {}
    recorded[key] = value
    DIGESTS.write_text(json.dumps(dict(sorted(recorded.items())), indent=1) + "\n")


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_the_streams_of_every_env_id_are_unchanged(env_id, seed):
    key = f"{env_id} seed={seed} steps={STEPS}"
    got = digest(env_id, seed)
    if UPDATE:
        record(key, got)
        return
    recorded = json.loads(DIGESTS.read_text())
    assert key in recorded, (
        f"no digest recorded for {key!r}: record it with TRACK_ENVS_UPDATE_DIGESTS=1 "
        "(see the module docstring)"
    )
    base, _, version = env_id.rpartition("-v")
    assert got == recorded[key], (
        f"the streams of {env_id} changed: register a new version ({base}-v{int(version) + 1}) and keep "
        "the old one's streams "
        f"({key}: {got} != {recorded[key]})"
    )


def test_every_recorded_digest_belongs_to_a_registered_id():
    recorded = json.loads(DIGESTS.read_text())
    assert {key.split(" ")[0] for key in recorded} <= set(ENV_IDS)


class Recast(gym.ObservationWrapper):
    """Emits the observation with its keys reversed and, optionally, the detections recast."""

    def __init__(self, env, dtype=None):
        super().__init__(env)
        self.dtype = dtype

    def observation(self, observation):
        out = {k: observation[k] for k in reversed(list(observation))}
        if self.dtype is not None:
            out["detections"] = out["detections"].astype(self.dtype)
        return out


def test_the_digest_sees_dtypes_but_not_key_order():
    plain = stream_digest(gym.make("SineTarget-v0"), 0, steps=5)
    assert stream_digest(Recast(gym.make("SineTarget-v0")), 0, steps=5) == plain
    assert stream_digest(Recast(gym.make("SineTarget-v0"), np.float64), 0, steps=5) != plain
    assert stream_digest(gym.make("SineTarget-v0"), 0, steps=4) != plain
