"""SortingPrediction on hand-built frames: errors, hits, misses, NEES, eligibility."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.contracts.report import empty_report
from track_envs.contracts.sorting_channel import empty_sorting, pack_sorting
from track_envs.metrics import SortingPrediction

ROWS = 8


def truth(visible_ids=(), crossings=()):
    ids = np.full(ROWS, -1, dtype=np.int64)
    ids[: len(visible_ids)] = visible_ids
    out = {
        "ids": ids,
        "positions": np.zeros((ROWS, 2)),
        "visible": ids >= 0,
        "nozzle_ids": np.full(ROWS, -1, dtype=np.int64),
        "nozzle_times": np.zeros(ROWS),
        "nozzle_lateral": np.zeros(ROWS),
    }
    for k, (i, t, y) in enumerate(crossings):
        out["nozzle_ids"][k], out["nozzle_times"][k], out["nozzle_lateral"][k] = i, t, y
    return out


def report(tracks=(), predictions=()):
    """``tracks``: (track id, detection row); ``predictions``: (track id, t, y, var_t, var_y)."""
    r = empty_report(ROWS, (2,))
    for k, (i, d) in enumerate(tracks):
        r["ids"][k], r["detection"][k], r["mask"][k] = i, d, 1
    if predictions:
        p = np.array(predictions, dtype=float)
        cov = np.zeros((len(p), 2, 2))
        cov[:, 0, 0], cov[:, 1, 1] = p[:, 3], p[:, 4]
        r.update(pack_sorting(p[:, 0].astype(np.int64), p[:, 1:3], cov, ROWS))
    else:
        r.update(empty_sorting(ROWS))
    return r


def detections(*sources):
    out = np.full(ROWS, -1, dtype=np.int64)
    out[: len(sources)] = sources
    return out


def run_case():
    m = SortingPrediction()
    # particles 1, 2, 3 in view for 3 frames; track 10 follows 1 (row 0), 11 follows 2 (row 1);
    # particle 3 has no track; particle 4 is in view for one frame only
    for frame in range(3):
        visible = (1, 2, 3, 4) if frame == 0 else (1, 2, 3)
        m.update(truth(visible), detections(1, 2, 3), report([(10, 0), (11, 1)]))
    # both tracks are deleted and predict their crossings (var_t = 1 ms², var_y = 1 mm²)
    m.update(
        truth(),
        detections(),
        report(predictions=[(10, 0.035, 0.1, 1e-6, 1e-6), (11, 0.04, 0.05, 1e-6, 1e-6)]),
    )
    # the crossings: 1 hit (1 ms, 0.5 mm off), 2 off by 3 mm laterally, 3 and 4 without prediction
    m.update(
        truth(crossings=[(1, 0.036, 0.1005), (2, 0.04, 0.053), (3, 0.041, 0.02), (4, 0.02, 0.1)]),
        detections(),
        report(),
    )
    return m.compute()


def test_hand_built_errors_hits_and_misses():
    out = run_case()
    assert out["sorting_particles"] == 3  # particle 4 was in view in one frame only
    assert out["sorting_predicted"] == pytest.approx(2 / 3)
    assert out["sorting_hit_rate"] == pytest.approx(1 / 3)
    assert out["sorting_time_bias_ms"] == pytest.approx(-0.5)
    assert out["sorting_time_rmse_ms"] == pytest.approx(np.sqrt((1.0**2 + 0.0) / 2))
    assert out["sorting_lateral_rmse_mm"] == pytest.approx(np.sqrt((0.5**2 + 3.0**2) / 2))
    assert out["sorting_lateral_p50_mm"] == pytest.approx(1.75)
    # NEES: (1 ms)²/1 ms² + (0.5 mm)²/1 mm² = 1.25 and 0 + 9 = 9
    assert out["sorting_nees"] == pytest.approx((1.25 + 9.0) / 2)
    assert out["sorting_nees_in_95"] == pytest.approx(0.5)
    assert out["sorting_unmatched_predictions"] == 0


def test_tolerances_are_configurable():
    m = SortingPrediction(lateral_tolerance=4e-3, time_tolerance=0.5e-3)
    base = run_case()
    m2 = SortingPrediction(lateral_tolerance=4e-3)
    for metric in (m, m2):
        for _ in range(3):
            metric.update(truth((1, 2, 3)), detections(1, 2, 3), report([(10, 0), (11, 1)]))
        metric.update(
            truth(),
            detections(),
            report(predictions=[(10, 0.035, 0.1, 1e-6, 1e-6), (11, 0.04, 0.05, 1e-6, 1e-6)]),
        )
        metric.update(
            truth(crossings=[(1, 0.036, 0.1005), (2, 0.04, 0.053), (3, 0.041, 0.02)]), detections(), report()
        )
    assert m.compute()["sorting_hit_rate"] == pytest.approx(1 / 3)  # only particle 2: on time, within 4 mm
    assert m2.compute()["sorting_hit_rate"] == pytest.approx(2 / 3)
    assert base["sorting_hit_rate"] == pytest.approx(1 / 3)


def test_the_last_prediction_counts_and_coasting_keeps_the_particle():
    m = SortingPrediction()
    for _ in range(3):
        m.update(truth((1,)), detections(1), report([(10, 0)]))
    m.update(truth((1,)), detections(), report([(10, -1)], predictions=[(10, 0.1, 0.0, 1e-6, 1e-6)]))
    m.update(truth(), detections(), report(predictions=[(10, 0.05, 0.02, 1e-6, 1e-6)]))
    m.update(truth(crossings=[(1, 0.05, 0.02)]), detections(), report())
    out = m.compute()
    assert out["sorting_hit_rate"] == 1.0
    assert out["sorting_time_rmse_ms"] == 0.0


def test_reports_without_the_channel_and_without_crossings():
    m = SortingPrediction()
    r = empty_report(ROWS, (2,))
    for _ in range(4):
        m.update(truth((1,)), detections(1), r)
    out = m.compute()
    assert out["sorting_particles"] == 0 and np.isnan(out["sorting_hit_rate"])
    m.update(truth(crossings=[(1, 0.05, 0.02)]), detections(), r)
    out = m.compute()
    assert (
        out["sorting_particles"] == 1 and out["sorting_hit_rate"] == 0.0 and out["sorting_predicted"] == 0.0
    )


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="lateral_tolerance"):
        SortingPrediction(lateral_tolerance=0.0)
    with pytest.raises(ValueError, match="min_visible_frames"):
        SortingPrediction(min_visible_frames=0)
