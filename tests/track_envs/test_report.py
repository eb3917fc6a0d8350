"""The report contract: packing, validation, padding rules."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.report import empty_report, pack_report, report_space, validate_report


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
        validate_report(space.sample(), 6, (2,), np.array([1, 0, 1, 0], np.int8))


def test_duplicate_ids_are_kept_as_distinct_rows():
    report = pack_report(np.array([1, 1]), np.zeros((2, 2)), np.array([-1, -1]), 3)
    assert len(validate_report(report, 3, (2,), np.zeros(1, np.int8))) == 2


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
        "ids": rng.integers(0, 10**12, size=tracks),
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
