"""The report contract: packing, validation, padding rules."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from track_envs.contracts.report import (
    ID_LIMIT,
    ReportSpace,
    empty_report,
    pack_report,
    report_space,
    validate_report,
)


def test_pack_report_pads_and_refuses_overflow():
    report = pack_report(np.array([4, 7]), np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([0, -1]), 5)
    assert report["mask"].tolist() == [1, 1, 0, 0, 0]
    assert report["positions"].dtype == np.float32 and report["ids"].dtype == np.int64
    with pytest.raises(ValueError, match="3 live tracks do not fit a report of max_tracks=2"):
        pack_report(np.arange(3), np.zeros((3, 2)), np.zeros(3, int), 2)


def test_detection_index_pointing_at_padding_or_out_of_range_reads_as_minus_one():
    report = pack_report(np.arange(3), np.zeros((3, 2)), np.array([1, 2, 99]), 4)
    detection_mask = np.array([1, 1, 0, 0], dtype=np.int8)
    valid = validate_report(report, 4, (2,), detection_mask)
    assert valid.detection.tolist() == [1, -1, -1]


def test_masked_out_rows_are_ignored_even_if_not_finite():
    report = empty_report(3, (2,))
    report["positions"][1] = np.nan
    assert len(validate_report(report, 3, (2,), np.zeros(4, np.int8))) == 0


def test_mask_values_other_than_zero_and_one_are_named():
    report = empty_report(3, (2,))
    report["mask"][2] = 5
    with pytest.raises(ValueError, match=r"rows \[2\]"):
        validate_report(report, 3, (2,), np.zeros(4, np.int8))


def test_every_space_sample_validates():
    space = report_space(6, (2,), np.zeros(2), np.ones(2), 4)
    space.seed(0)
    for _ in range(20):
        sample = space.sample()
        checked = validate_report(sample, 6, (2,), np.array([1, 0, 1, 0], np.int8))
        live = sample["ids"][sample["mask"] == 1]
        assert len(np.unique(live)) == len(live) and (live >= 0).all()
        assert checked is not None


def test_repeated_live_ids_are_rejected_naming_rows_and_ids():
    report = pack_report(np.array([1, 5, 1, 7, 5]), np.zeros((5, 2)), np.full(5, -1), 6)
    with pytest.raises(ValueError, match=r"distinct.*rows \[0, 1, 2, 4\] repeat ids \[1, 5\]"):
        validate_report(report, 6, (2,), np.zeros(1, np.int8))


def test_repeated_ids_on_padding_rows_are_ignored():
    report = pack_report(np.array([3, 4]), np.zeros((2, 2)), np.full(2, -1), 5)
    report["ids"][2:] = 4  # padding may hold anything
    assert validate_report(report, 5, (2,), np.zeros(1, np.int8)).ids.tolist() == [3, 4]


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_negative_live_ids_are_rejected(dtype: type) -> None:
    report = pack_report(np.array([-1, 2, -7]), np.zeros((3, 2)), np.full(3, -1), 4)
    report["ids"] = report["ids"].astype(dtype)
    with pytest.raises(ValueError, match=r"ids'\] must be in \[0, 2\*\*62\].*rows \[0, 2\] hold \[-1, -7\]"):
        validate_report(report, 4, (2,), np.zeros(1, np.int8))


@pytest.mark.parametrize("dtype", [np.int64, np.uint64])
def test_ids_above_the_space_bound_are_rejected(dtype: type) -> None:
    report = pack_report(np.array([ID_LIMIT, 0]), np.zeros((2, 2)), np.full(2, -1), 3)
    report["ids"] = report["ids"].astype(dtype)
    assert validate_report(report, 3, (2,), np.zeros(1, np.int8)).ids.tolist() == [ID_LIMIT, 0]
    report["ids"][1] = ID_LIMIT + 1 if dtype == np.int64 else np.uint64(2**64 - 1)
    with pytest.raises(ValueError, match=r"rows \[1\] hold"):
        validate_report(report, 3, (2,), np.zeros(1, np.int8))


def test_the_bound_is_the_action_space_bound():
    space = report_space(3, (2,), np.zeros(2), np.ones(2), 4)
    assert int(space["ids"].high.min()) == ID_LIMIT and int(space["ids"].low.max()) == 0


def test_every_live_track_reported_as_id_42_is_rejected_by_the_env():
    """Giving every live gnn track one id used to score a better MOTA than honest ids."""
    from agents import make_agent

    env = gym.make("BeltSorter-v0")
    agent = make_agent("gnn")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    report = agent.act(obs)
    live = np.flatnonzero(report["mask"] == 1)
    assert len(live) >= 2
    env.step(report)  # the honest report is fine
    report = agent.act(obs)
    report["ids"][report["mask"] == 1] = 42
    with pytest.raises(ValueError, match=r"repeat ids \[42\]"):
        env.step(report)
    report["ids"][report["mask"] == 1] = -1
    with pytest.raises(ValueError, match=r"must be in \[0, 2\*\*62\]"):
        env.step(report)


def test_space_samples_have_distinct_ids_and_follow_the_space_seed():
    space = report_space(200, (2,), np.zeros(2), np.ones(2), 4)
    assert isinstance(space, ReportSpace)
    space.seed(3)
    first = [space.sample() for _ in range(5)]
    space.seed(3)
    again = [space.sample() for _ in range(5)]
    for a, b in zip(first, again, strict=True):
        assert len(np.unique(a["ids"])) == 200 and a["ids"].min() >= 0
        np.testing.assert_array_equal(a["ids"], b["ids"])
        assert space.contains(a)


def test_space_sample_passes_masks_to_the_boxes_like_a_dict_space():
    space = report_space(4, (2,), np.zeros(2), np.ones(2), 4)
    sample = space.sample(mask=dict.fromkeys(space.spaces))
    assert space.contains(sample)
    with pytest.raises(gym.error.Error, match="cannot be provided a mask"):
        space.sample(mask={**dict.fromkeys(space.spaces), "ids": np.ones(4, np.int8)})
    with pytest.raises(ValueError, match="Only one of"):
        space.sample(mask=dict.fromkeys(space.spaces), probability=dict.fromkeys(space.spaces))


def test_contains_refuses_repeated_live_ids():
    space = report_space(4, (2,), np.zeros(2), np.ones(2), 4)
    report = pack_report(np.array([2, 2]), np.zeros((2, 2)), np.full(2, -1), 4)
    assert not space.contains(report)
    report["mask"][1] = 0
    assert space.contains(report)


@pytest.mark.parametrize("env_id", track_envs.ENV_IDS)
def test_many_samples_of_every_env_action_space_validate(env_id: str) -> None:
    env = gym.make(env_id)
    base = env.unwrapped
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(300):
        sample = env.action_space.sample()
        live = validate_report(sample, base.sensor_spec.max_tracks, base.position_shape, obs["mask"])
        assert len(np.unique(live.ids)) == len(live.ids) == int(sample["mask"].sum())
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.sample())
        assert np.isfinite(reward)


def _reference_live_rows(report, detection_mask):
    """The contract in plain numpy: live rows, detection read as -1 unless it points at a detection."""
    live = report["mask"] != 0
    det = report["detection"][live].astype(np.int64)
    n = len(detection_mask)
    in_range = (det >= 0) & (det < n)
    points_at_detection = np.zeros(len(det), bool)
    points_at_detection[in_range] = detection_mask[det[in_range]] == 1
    return (
        report["ids"][live].astype(np.int64),
        report["positions"][live].astype(np.float64),
        np.where(points_at_detection, det, -1),
    )


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("mask_dtype", [np.int8, np.bool_, np.int64])
def test_validation_keeps_exactly_the_live_rows(seed: int, mask_dtype: type) -> None:
    rng = np.random.default_rng(seed)
    tracks, detections = int(rng.integers(1, 40)), int(rng.integers(0, 30))
    report = {
        "ids": rng.choice(10**12, size=tracks, replace=False),
        "positions": rng.normal(size=(tracks, 17, 2)).astype(np.float32),
        "detection": rng.integers(-3, detections + 3, size=tracks),
        "mask": (rng.random(tracks) < 0.6).astype(mask_dtype),
    }
    report["positions"][report["mask"] == 0] = np.nan  # padding may hold anything
    detection_mask = (rng.random(detections) < 0.7).astype(np.int8)
    valid = validate_report(report, tracks, (17, 2), detection_mask)
    ids, positions, detection = _reference_live_rows(report, detection_mask)
    np.testing.assert_array_equal(valid.ids, ids)
    np.testing.assert_array_equal(valid.positions, positions)
    np.testing.assert_array_equal(valid.detection, detection)
    assert valid.positions.shape == (len(ids), 17, 2) and valid.positions.dtype == np.float64


def test_non_finite_live_positions_are_named_by_row() -> None:
    report = pack_report(np.arange(3), np.zeros((3, 2)), np.full(3, -1), 4)
    report["positions"][2, 1] = np.inf
    with pytest.raises(ValueError, match=r"non-finite values in masked-in rows \[2\]"):
        validate_report(report, 4, (2,), np.zeros(2, np.int8))
