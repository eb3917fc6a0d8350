"""The report's optional sorting channel: reports with and without it validate; bad channels are named."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import track_envs  # noqa: F401
from track_envs.contracts.report import REPORT_KEYS, empty_report, validate_report
from track_envs.contracts.sorting_channel import SORTING_KEYS, empty_sorting, pack_sorting

ROWS = 4
MASK = np.ones(8, dtype=np.int8)


def with_channel():
    r = empty_report(ROWS, (2,))
    r["ids"][:2], r["mask"][:2] = [3, 5], 1
    cov = np.array([[[1e-6, 1e-8], [1e-8, 2e-6]]])
    r.update(pack_sorting(np.array([7]), np.array([[0.35, 0.09]]), cov, ROWS))
    return r


def test_reports_without_the_channel_still_validate():
    r = empty_report(ROWS, (2,))
    r["ids"][0], r["mask"][0] = 1, 1
    checked = validate_report(r, ROWS, (2,), MASK)
    assert checked.sorting is None and checked.ids.tolist() == [1]


def test_a_report_with_the_channel_validates_and_keeps_its_rows():
    checked = validate_report(with_channel(), ROWS, (2,), MASK)
    assert checked.ids.tolist() == [3, 5]
    assert checked.sorting is not None and checked.sorting.ids.tolist() == [7]
    np.testing.assert_allclose(checked.sorting.mean, [[0.35, 0.09]])


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("sorting_mean", np.full((ROWS, 2), np.nan), "sorting_mean"),
        ("sorting_mean", np.zeros((ROWS, 3)), "sorting_mean"),
        ("sorting_cov", -np.ones((ROWS, 2, 2)), "sorting_cov"),
        ("sorting_mask", np.full(ROWS, 2, dtype=np.int8), "sorting_mask"),
        ("sorting_ids", np.full(ROWS, -1, dtype=np.int64), "sorting_ids"),
    ],
)
def test_a_bad_channel_is_named(key, value, message):
    r = with_channel()
    r[key] = value
    with pytest.raises(ValueError, match=message):
        validate_report(r, ROWS, (2,), MASK)


def test_a_partial_channel_names_the_missing_keys():
    r = with_channel()
    del r["sorting_cov"]
    with pytest.raises(ValueError, match="sorting_cov"):
        validate_report(r, ROWS, (2,), MASK)


def test_the_action_space_samples_plain_reports_and_contains_channelled_ones():
    env = gym.make("BeltSorter-v0", max_tracks=ROWS)
    space = env.action_space
    space.seed(0)
    sample = space.sample()
    assert set(sample) == set(REPORT_KEYS)
    assert space.contains(sample)
    validate_report(sample, ROWS, (2,), np.ones(256, dtype=np.int8))
    channelled = dict(sample) | empty_sorting(ROWS)
    assert space.contains(channelled)
    channelled["sorting_mask"] = np.ones(ROWS, dtype=np.int8)
    channelled["sorting_mean"] = np.full((ROWS, 2), np.inf)
    assert not space.contains(channelled)
    assert set(SORTING_KEYS) & set(space.spaces) == set()


def test_check_env_passes_and_env_steps_with_the_channel():
    env = gym.make("BeltSorter-v0", max_tracks=ROWS)
    check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=0)
    env.step(with_channel())
