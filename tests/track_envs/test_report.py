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
