"""The knobs' action mapping: log scales, ends, round trips, and the checks of ranges and actions."""

from __future__ import annotations

import numpy as np
import pytest

from track_apps.tuning.knobs import DEFAULT_RANGES, Knob, check_action, make_knobs


@pytest.mark.parametrize("name", list(DEFAULT_RANGES))
def test_the_ends_and_the_middle_of_the_action_map_to_the_range(name):
    (knob,) = [k for k in make_knobs() if k.name == name]
    lo, hi = DEFAULT_RANGES[name]
    assert knob.value(-1.0) == pytest.approx(lo)
    assert knob.value(1.0) == pytest.approx(hi)
    for a in np.linspace(-1, 1, 9):
        assert knob.action(knob.value(a)) == pytest.approx(a, abs=1e-9)


def test_equal_action_steps_are_equal_factors():
    scale = Knob("noise_scale", 0.25, 16.0)
    values = [scale.value(a) for a in (-1.0, -0.5, 0.0, 0.5, 1.0)]
    np.testing.assert_allclose(np.diff(np.log(values)), np.log(2.0) * 1.5)
    gate = Knob("p_gate", 0.9, 0.999999)
    misses = [1 - gate.value(a) for a in (-1.0, 0.0, 1.0)]
    np.testing.assert_allclose(misses, [0.1, 10**-3.5, 1e-6], rtol=1e-6)


def test_actions_beyond_the_range_clip():
    knob = Knob("recovery_inflation", 1.0, 1000.0)
    assert knob.action(5000.0) == 1.0 and knob.action(0.5) == -1.0


@pytest.mark.parametrize(
    ("ranges", "message"),
    [
        ({"gate": (0.9, 0.99)}, "unknown knob \\['gate'\\]; the knobs are"),
        ({"p_gate": (0.9, 1.0)}, "range of p_gate: each end must be a probability in \\(0, 1\\)"),
        ({"p_gate": (0.99, 0.9)}, "range of p_gate must have low < high"),
        ({"recovery_inflation": (0.5, 10.0)}, "each end must be a finite number >= 1"),
        ({"noise_scale": (0.0, 4.0)}, "each end must be a finite number > 0"),
        ({"noise_scale": (1.0, float("inf"))}, "each end must be a finite number > 0"),
        ({"noise_scale": 4.0}, "range of noise_scale must be \\(low, high\\)"),
        ({"noise_scale": "14"}, "range of noise_scale must be \\(low, high\\)"),
    ],
)
def test_bad_ranges_say_what_is_wrong(ranges, message):
    with pytest.raises(ValueError, match=message):
        make_knobs(ranges)


@pytest.mark.parametrize(
    ("action", "message"),
    [
        (np.zeros(2), "action must have shape \\(3,\\) \\(one entry per knob\\), got shape \\(2,\\)"),
        (np.zeros((1, 3)), "got shape \\(1, 3\\)"),
        (np.array([0.0, 1.5, 0.0]), "in \\[-1, 1\\], got \\[1.5\\] at \\[1\\]"),
        (np.array([np.nan, 0.0, 0.0]), "must be finite"),
        ("up", "action must be a numeric array of shape \\(3,\\)"),
    ],
)
def test_bad_actions_say_what_is_wrong(action, message):
    with pytest.raises(ValueError, match=message):
        check_action(action, 3)
