"""Constructor argument checks: every numeric argument of every env says it must be a number."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from track_envs.envs.belt_physics import BeltParams
from track_envs.infra.arguments import (
    check_int,
    check_non_negative,
    check_number,
    check_positive,
    check_probability,
    check_vector,
)


def numeric_arguments(env_id: str) -> list[str]:
    """The keyword arguments of an env's constructor (and of its bases') annotated as numbers."""
    cls = gym.spec(env_id).entry_point
    assert isinstance(cls, str)
    module, name = cls.split(":")
    env_class = getattr(__import__(module, fromlist=[name]), name)
    names: list[str] = []
    for klass in env_class.__mro__:
        if "__init__" not in vars(klass) or klass.__module__.startswith("gymnasium"):
            continue
        for param in inspect.signature(vars(klass)["__init__"]).parameters.values():
            parts = {part.strip() for part in str(param.annotation).split("|")}
            numeric = parts <= {"float", "int", "None"} and bool(parts & {"float", "int"})
            if param.kind is param.KEYWORD_ONLY and numeric and param.name not in names:
                names.append(param.name)
    return names


CASES = [(env_id, name) for env_id in track_envs.ENV_IDS for name in numeric_arguments(env_id)]


def test_every_env_has_numeric_arguments_to_check():
    assert {env_id for env_id, _ in CASES} == set(track_envs.ENV_IDS)
    assert ("BeltSorter-v0", "noise_std") in CASES and ("PiecewiseTarget-v0", "p_detect") in CASES


@pytest.mark.parametrize(("env_id", "name"), CASES)
@pytest.mark.parametrize("value", ["1e-4", [1.0], True])
def test_a_non_number_is_named_as_such(env_id: str, name: str, value: object) -> None:
    """``noise_std="1e-4"`` used to fail inside numpy with a ufunc TypeError."""
    with pytest.raises(ValueError, match=rf"^{name} must be (a number|an integer)") as caught:
        gym.make(env_id, **{name: value})
    assert repr(value) in str(caught.value)


@pytest.mark.parametrize("field", ["belt_speed", "feed_rate", "substeps", "drop_x"])
def test_belt_physics_fields_say_they_must_be_numbers(field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field} must be (a number|an integer)"):
        BeltParams(**{field: "1"})


def test_particle_kind_weights_must_be_numbers() -> None:
    with pytest.raises(ValueError, match=r"particle_kind\['cylinder'\] must be a number"):
        gym.make("BeltSorter-v0", particle_kind={"cylinder": "1"})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"offset": ("a", 1.0)}, r"offset must be 2 finite numbers, got \('a', 1.0\)"),
        ({"offset": (1.0, 2.0, 3.0)}, "offset must be 2 finite numbers"),
        ({"rotation_deg": np.inf}, "rotation_deg must be a finite number"),
        ({"occlusion_length": 2.5}, r"occlusion_length must be an integer >= 0, got 2.5 \(float\)"),
    ],
)
def test_vector_and_integer_arguments_are_named(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make("SineTarget-v0", **kwargs)


def test_segment_steps_and_region_entries_are_named() -> None:
    with pytest.raises(ValueError, match=r"segment_steps\[1\] must be an integer >= 5, got 2"):
        gym.make("PiecewiseTarget-v0", segment_steps=(5, 2))
    with pytest.raises(ValueError, match=r"segment_steps must be integers \(min, max\), got 7"):
        gym.make("PiecewiseTarget-v0", segment_steps=7)
    with pytest.raises(ValueError, match=r"region\[1\] must be 2 finite numbers, got 'far'"):
        gym.make("BeltReplay-v0", region=((0.0, 0.0), "far"))


def test_keypoint_noise_alias_is_named_by_the_name_given() -> None:
    with pytest.raises(ValueError, match=r"^noise_std must be a number"):
        gym.make("KeypointWalkers-v0", noise_std="0.3")
    with pytest.raises(ValueError, match=r"^keypoint_noise must be a finite number >= 0"):
        gym.make("KeypointWalkers-v0", keypoint_noise=-1.0)


def test_checks_convert_and_bound() -> None:
    assert check_number("x", np.float32(1.5)) == 1.5 and isinstance(check_number("x", 2), float)
    assert check_number("x", np.array(3.0)) == 3.0
    assert check_probability("p", 1) == 1.0 and check_non_negative("s", 0) == 0.0
    assert check_positive("c", np.int64(4)) == 4.0
    assert check_int("n", np.int16(3), 1, 3) == 3 and type(check_int("n", np.int64(2), 0)) is int
    np.testing.assert_array_equal(check_vector("v", np.array([1, 2]), 2), [1.0, 2.0])
    for check, bad, message in [
        (check_probability, 1.5, r"must be a probability in \[0, 1\], got 1.5"),
        (check_probability, np.nan, "must be a probability"),
        (check_non_negative, -1e-9, "must be a finite number >= 0"),
        (check_positive, 0.0, "must be a finite number > 0"),
        (check_positive, None, r"must be a number \(finite, > 0\), got None \(NoneType\)"),
        (check_number, np.bool_(True), r"must be a number, got .*True"),
    ]:
        with pytest.raises(ValueError, match=message):
            check(bad, bad)
    with pytest.raises(ValueError, match=r"must be an integer in \[1, 20\], got 21"):
        check_int("substeps", 21, 1, 20)
    with pytest.raises(ValueError, match=r"must be an integer >= 1, got 3.0 \(float\)"):
        check_int("n", 3.0, 1)
