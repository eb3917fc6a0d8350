"""The constant-velocity stream: its statistics, its determinism, its scoring and its argument checks."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.contracts.report import pack_report
from track_envs.streams.constant_velocity import (
    ConstantVelocityStream,
    constant_velocity_stream,
    score_tracker,
)


def _streams(seeds: range, **kwargs) -> list[ConstantVelocityStream]:
    return [constant_velocity_stream(np.random.default_rng(seed), **kwargs) for seed in seeds]


@pytest.fixture(scope="module")
def streams() -> list[ConstantVelocityStream]:
    """40 short streams at the defaults (150 targets, p_D 0.9, 5 clutter detections per frame)."""
    return _streams(range(40), frames=60)


def test_targets_in_view_average_n(streams):
    counts = np.array([[len(s.truth_ids[t]) for t in (0, 30, 59)] for s in streams])
    assert abs(counts.mean() - 150) < 5  # Poisson(150) per frame: std 12.2, 120 draws
    assert counts.min() > 100 and counts.max() < 200


def test_a_flow_in_every_direction_keeps_n_in_view():
    counts = [
        len(s.truth_ids[t])
        for s in _streams(range(20), frames=60, velocity=(0.0, 0.0), velocity_std=(0.8, 0.8))
        for t in (0, 59)
    ]
    assert abs(np.mean(counts) - 150) < 6


def test_clutter_detection_probability_and_noise(streams):
    clutter, detected, visible, errors = [], 0, 0, []
    for s in streams:
        for t, (obs, rows) in enumerate(zip(s.observations, s.detection_ids, strict=True)):
            live = obs["mask"] == 1
            clutter.append(int(np.sum(live & (rows == -1))))
            ids = rows[live & (rows >= 0)]
            assert len(np.unique(ids)) == len(ids)  # one detection per target at most
            detected += len(ids)
            visible += len(s.truth_ids[t])
            where = {int(i): k for k, i in enumerate(s.truth_ids[t])}
            truth = s.truth_positions[t][[where[int(i)] for i in ids]]
            errors.append(obs["detections"][live & (rows >= 0)] - truth)
            assert np.all(obs["mask"][~live] == 0) and np.all(rows[~live] == -1)
    assert abs(np.mean(clutter) - 5.0) < 0.25  # 2400 frames of Poisson(5): std err 0.046
    assert abs(detected / visible - 0.9) < 0.005
    assert np.std(np.concatenate(errors)) == pytest.approx(1e-4, rel=0.03)


def test_spec_declares_the_sensor(streams):
    spec = streams[0].spec
    assert (spec.dt, spec.dim, spec.noise_std, spec.p_detect, spec.clutter_rate) == (0.01, 2, 1e-4, 0.9, 5.0)
    assert spec.region_low == (0.0, 0.0) and spec.region_high == (0.5, 0.3)
    most = max(int(obs["mask"].sum()) for obs in streams[0].observations)
    assert spec.max_detections == most and spec.max_tracks >= 2 * most


def test_truth_is_inside_the_window_and_moves_at_constant_velocity(streams):
    s = streams[0]
    for x in s.truth_positions:
        assert np.all((x >= 0) & (x <= [0.5, 0.3]))
    # a target seen in three frames in a row moved the same step both times
    steps = []
    for t in range(len(s.truth_ids) - 2):
        common = np.intersect1d(np.intersect1d(s.truth_ids[t], s.truth_ids[t + 1]), s.truth_ids[t + 2])
        x = [s.truth_positions[t + k][np.searchsorted(s.truth_ids[t + k], common)] for k in range(3)]
        np.testing.assert_allclose(x[2] - x[1], x[1] - x[0], atol=1e-12)
        steps.append(x[1] - x[0])
    v = np.concatenate(steps) / 0.01
    assert abs(v[:, 0].mean() - 1.0) < 0.02 and abs(v[:, 1].mean()) < 0.02
    assert v[:, 0].std() == pytest.approx(0.05, rel=0.2)


def test_rows_are_shuffled(streams):
    rows = streams[0].detection_ids[0]
    live = rows[: int(streams[0].observations[0]["mask"].sum())]
    # clutter rows are not all at the end (the sensor appends them)
    assert np.any(live[: len(live) // 2] == -1) or np.any(np.diff(live[live >= 0]) < 0)


def test_the_seed_fixes_the_stream():
    a, b, c = (constant_velocity_stream(np.random.default_rng(s), frames=20) for s in (3, 3, 4))
    for x, y in zip(a.observations, b.observations, strict=True):
        np.testing.assert_array_equal(x["detections"], y["detections"])
        np.testing.assert_array_equal(x["mask"], y["mask"])
    assert all(np.array_equal(x, y) for x, y in zip(a.truth_ids, b.truth_ids, strict=True))
    assert not np.array_equal(a.observations[0]["detections"], c.observations[0]["detections"])


class _Oracle:
    """Reports the truth of each frame under the truth ids (the perfect tracker)."""

    def __init__(self, stream: ConstantVelocityStream) -> None:
        self.stream = stream

    def reset(self, spec, seed=None) -> None:
        self.t = 0

    def act(self, obs):
        ids, x = self.stream.truth_ids[self.t], self.stream.truth_positions[self.t]
        self.t += 1
        return pack_report(ids, x, np.full(len(ids), -1), self.stream.spec.max_tracks)


def test_score_tracker_of_the_truth_is_perfect():
    s = constant_velocity_stream(np.random.default_rng(0), frames=30)
    figures = score_tracker(_Oracle(s), s)
    assert figures["mota"] == 1.0 and figures["idf1"] == 1.0 and figures["id_switches"] == 0
    assert figures["hota"] == pytest.approx(1.0)
    assert figures["num_objects"] == sum(len(i) for i in s.truth_ids)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"n_targets": 0}, "n_targets"),
        ({"frames": 0}, "frames"),
        ({"frames": 2.0}, "frames"),
        ({"p_detect": 1.5}, "p_detect"),
        ({"clutter_rate": -1.0}, "clutter_rate"),
        ({"noise_std": -1e-4}, "noise_std"),
        ({"dt": 0.0}, "dt"),
        ({"size": (0.5, 0.0)}, r"size\[1\]"),
        ({"size": (0.5,)}, "size"),
        ({"velocity": (np.nan, 0.0)}, r"velocity\[0\]"),
        ({"velocity_std": (0.1, -0.1)}, r"velocity_std\[1\]"),
        ({"velocity": (0.0, 0.0), "velocity_std": (0.0, 0.0)}, "velocity"),
    ],
)
def test_bad_arguments_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        constant_velocity_stream(np.random.default_rng(0), **kwargs)


def test_rng_must_be_a_generator():
    with pytest.raises(ValueError, match="rng"):
        constant_velocity_stream(42)  # type: ignore[arg-type]


def test_constant_density_at_the_default_count_is_the_default_stream():
    from track_envs.streams.constant_velocity import constant_density

    assert constant_density(150) == {"n_targets": 150.0, "size": (0.5, 0.3), "clutter_rate": 5.0}
    a = constant_velocity_stream(np.random.default_rng(3), frames=5, **constant_density(150))
    b = constant_velocity_stream(np.random.default_rng(3), frames=5)
    for x, y in zip(a.observations, b.observations, strict=True):
        np.testing.assert_array_equal(x["detections"], y["detections"])
    with pytest.raises(ValueError, match="n_targets"):
        constant_density(0.0)


def test_a_hundred_thousand_targets_in_view_at_the_default_density():
    from track_envs.streams.constant_velocity import constant_density

    kwargs = constant_density(100_000)
    s = np.sqrt(100_000 / 150)
    np.testing.assert_allclose(kwargs["size"], (0.5 * s, 0.3 * s))
    assert kwargs["clutter_rate"] == pytest.approx(5 * 100_000 / 150)
    stream = constant_velocity_stream(np.random.default_rng(0), frames=3, **kwargs)
    for t in range(3):
        n = len(stream.truth_ids[t])
        assert abs(n - 100_000) < 5 * np.sqrt(100_000)  # Poisson(N)
        detected = int((stream.detection_ids[t] >= 0).sum())
        clutter = int(stream.observations[t]["mask"].sum()) - detected
        assert abs(detected - 0.9 * n) < 5 * np.sqrt(0.09 * n)
        assert abs(clutter - kwargs["clutter_rate"]) < 5 * np.sqrt(kwargs["clutter_rate"])
    # the density of the default scene: ≈150 targets per 0.15 m²
    assert stream.spec.region_high == pytest.approx((0.5 * s, 0.3 * s))
