"""Streams are versioned: what every registered env id emits is pinned by a digest.

The rule, and when a re-pin is allowed, are in docs/architecture.md ("Streams are versioned").

For every id (the ids of ``track_envs`` and GateTuning-v0 of ``track_apps.tuning``) and two seeds,
[`track_envs.testing.stream_digest`][track_envs.testing.stream_digest] hashes the first `STEPS` steps (fewer
where the episode ends earlier: GateTuning-v0 ends after 100 steps of 10 tracked frames each):
observations, rewards, ``terminated`` / ``truncated`` and the truth side of ``info``. The
digests are recorded in ``data/stream_digests.json``, one entry per id and seed: the digest and
the re-pins it went through, each with its reason. A change of what an id emits fails here and
needs a new version id (``ID-v1``) while the old id keeps its streams; the env class docstring's
"Version History" lists every version of the id.

The action is the simplest deterministic one: the empty report for the tracking envs (so the
reward is a function of the truth alone) and the zero action (the middle of every knob's range)
for GateTuning-v0.

To record the digests of a new id (an id that has digests is never recorded again)::

    TRACK_ENVS_RECORD_DIGESTS=1 python -m pytest tests/track_envs/test_stream_versions.py

To re-pin ids whose bits a new numpy, numba, scipy or pymunk (or another CPU) changed while
their env's code did not (the ids are named; the reason is stored beside each new digest)::

    TRACK_ENVS_REPIN_DIGESTS=BeltSorter-v0,BeltReplay-v0 TRACK_ENVS_REPIN_REASON="numpy 2.3 sums ..." \\
        python -m pytest tests/track_envs/test_stream_versions.py
"""

from __future__ import annotations

import inspect
import json
import os
import platform
import re
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import load_env_creator

import track_apps.tuning
import track_envs
from track_envs.testing import stream_digest

DIGESTS = Path(__file__).parent / "data" / "stream_digests.json"
#: "1": record the digests of ids that have none (never those of an id that has some).
RECORD = os.environ.get("TRACK_ENVS_RECORD_DIGESTS") == "1"
#: Comma-separated ids whose digests are replaced, with `REPIN_REASON` stored beside them.
REPIN = tuple(filter(None, (n.strip() for n in os.environ.get("TRACK_ENVS_REPIN_DIGESTS", "").split(","))))
REPIN_REASON = os.environ.get("TRACK_ENVS_REPIN_REASON", "").strip()
#: The libraries whose bits a re-pin may follow, noted beside its reason.
LIBRARIES = ("numpy", "numba", "scipy", "pymunk")
SEEDS = (0, 1)
STEPS = 200
#: ``info`` entries hashed where they differ from the default (GateTuning-v0 has no truth rows:
#: its truth side is the error count and the true sensor values).
INFO_KEYS = {track_apps.tuning.ENV_ID: ("knobs", "association_errors", "frames", "sensor")}
ENV_IDS = (*track_envs.ENV_IDS, track_apps.tuning.ENV_ID)
HEX_DIGEST = re.compile(r"[0-9a-f]{64}")


def load() -> dict[str, dict[str, Any]]:
    """The recorded entries by key (``"ID seed=S steps=N"``)."""
    return json.loads(DIGESTS.read_text()) if DIGESTS.exists() else {}


def key_id(key: str) -> str:
    return key.split(" ")[0]


#: The entries as they were when this test run started: an id is new when it had none then.
RECORDED = load()
NEW_IDS = frozenset(ENV_IDS) - {key_id(key) for key in RECORDED}


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


def write(key: str, entry: dict[str, Any]) -> None:
    recorded = load()
    recorded[key] = entry
    DIGESTS.write_text(json.dumps(dict(sorted(recorded.items())), indent=1) + "\n")


def check_repin() -> None:
    """Fail unless the re-pin asked for names registered ids and gives a reason."""
    unknown = sorted(set(REPIN) - set(ENV_IDS))
    assert not unknown, f"TRACK_ENVS_REPIN_DIGESTS names unregistered ids {unknown}; registered: {ENV_IDS}"
    assert not REPIN or REPIN_REASON, (
        f"re-pinning {list(REPIN)} needs TRACK_ENVS_REPIN_REASON: what changed the bits (a library "
        "version or the CPU) while the env's code did not"
    )


def repin_note(previous: str) -> dict[str, str]:
    """What a re-pin stores beside the new digest: the reason, the digest it replaces, the setup."""
    found = []
    for name in LIBRARIES:
        try:
            found.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            found.append(f"{name} absent")
    setup = ", ".join([*found, platform.machine() or "unknown machine"])
    return {"reason": REPIN_REASON, "previous": previous, "setup": setup}


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_the_streams_of_every_env_id_are_unchanged(env_id, seed):
    key = f"{env_id} seed={seed} steps={STEPS}"
    got = digest(env_id, seed)
    if RECORD and env_id in NEW_IDS:
        write(key, {"digest": got})
        return
    entry = load().get(key)
    assert entry is not None, (
        f"no digest recorded for {key!r}: record the digests of a new id with TRACK_ENVS_RECORD_DIGESTS=1 "
        "(see the module docstring)"
    )
    if env_id in REPIN and got != entry["digest"]:
        check_repin()
        write(key, {"digest": got, "repins": [*entry.get("repins", []), repin_note(entry["digest"])]})
        return
    base, _, number = env_id.rpartition("-v")
    refused = "TRACK_ENVS_RECORD_DIGESTS records only ids without digests. " if RECORD else ""
    assert got == entry["digest"], (
        f"the streams of {env_id} changed ({key}: {got} != {entry['digest']}). {refused}"
        "An id that has digests keeps its streams: register the changed env as "
        f"{base}-v{int(number) + 1}, with its entry in the Version History of the env class "
        "docstring. Only when a new numpy, numba, scipy or pymunk (or another CPU) changed the "
        "bits while the env's code did not, re-pin the id with TRACK_ENVS_REPIN_DIGESTS and "
        "TRACK_ENVS_REPIN_REASON (see the module docstring)"
    )


def test_a_repin_names_registered_ids_and_gives_its_reason():
    check_repin()


def test_every_recorded_digest_belongs_to_a_registered_id():
    assert {key_id(key) for key in load()} <= set(ENV_IDS)


def test_every_entry_holds_a_digest_and_every_repin_its_reason():
    for key, entry in load().items():
        assert set(entry) <= {"digest", "repins"} and HEX_DIGEST.fullmatch(entry["digest"]), (key, entry)
        for note in entry.get("repins", []):
            assert set(note) == {"reason", "previous", "setup"}, (key, note)
            assert note["reason"].strip() and HEX_DIGEST.fullmatch(note["previous"]), (key, note)


def version_history(env_id: str) -> str:
    """The "Version History" section of the docstring of the class an id's entry point names."""
    entry_point = gym.spec(env_id).entry_point
    creator = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
    doc = inspect.getdoc(creator) or ""
    _, found, rest = doc.partition("## Version History")
    assert found, f"the docstring of {creator.__qualname__} ({env_id}) has no '## Version History' section"
    return rest.split("\n## ")[0]


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_every_registered_id_has_its_entry_in_the_version_history(env_id):
    number = env_id.rpartition("-v")[2]
    history = version_history(env_id)
    assert re.search(rf"^[-*] v{number}\b", history, re.MULTILINE), (
        f"the Version History of {env_id}'s env class lists no v{number}:\n{history}"
    )


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
