"""The observation contract on the agent side: check_observation."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.contracts.observation import check_observation
from track_envs.values.types import SensorSpec

SPEC = SensorSpec(
    dt=1.0,
    dim=2,
    noise_std=0.1,
    p_detect=1.0,
    clutter_rate=0.0,
    region_low=(0.0, 0.0),
    region_high=(1.0, 1.0),
    max_detections=6,
    max_tracks=6,
)


def observation(mask=(1, 0, 1, 1, 0, 0), dtype=np.int8) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    mask = np.asarray(mask, dtype=dtype)
    detections = rng.random((6, 2)).astype(np.float32)
    detections[mask == 0] = 0
    return {"detections": detections, "mask": mask}


@pytest.mark.parametrize("dtype", [np.int8, np.int64, np.uint8, np.bool_])
def test_masked_in_rows_and_their_detections_are_returned(dtype: type) -> None:
    obs = observation(dtype=dtype)
    rows, z = check_observation(obs, SPEC)
    assert rows.tolist() == [0, 2, 3]
    assert z.dtype == np.float64
    np.testing.assert_array_equal(z, obs["detections"][[0, 2, 3]].astype(np.float64))


def test_keypoint_rows_keep_their_shape() -> None:
    detections = np.zeros((6, 17, 3), np.float32)
    detections[4] = 1.5
    rows, z = check_observation(
        {"detections": detections, "mask": np.array([0, 0, 0, 0, 1, 0], np.int8)}, SPEC, (17, 3)
    )
    assert rows.tolist() == [4] and z.shape == (1, 17, 3) and np.all(z == 1.5)


def test_an_empty_observation_is_valid() -> None:
    rows, z = check_observation(observation(mask=np.zeros(6)), SPEC)
    assert rows.shape == (0,) and z.shape == (0, 2)


@pytest.mark.parametrize("value", [2, -1, 5])
def test_mask_values_other_than_zero_and_one_are_named_by_row(value: int) -> None:
    """Mask 2 or -1 on padding rows used to read as "present" (padding rows became tracks)."""
    obs = observation()
    obs["mask"][[4, 5]] = value
    with pytest.raises(
        ValueError, match=rf"mask'\] must hold 0 or 1; rows \[4, 5\] hold \[{value}, {value}\]"
    ):
        check_observation(obs, SPEC)


def test_a_float_mask_is_refused() -> None:
    obs = observation(dtype=np.float64)
    with pytest.raises(ValueError, match=r"mask'\] must be a 0/1 integer array \(or bool\) .* got float64"):
        check_observation(obs, SPEC)


def test_non_finite_masked_in_rows_are_named() -> None:
    obs = observation()
    obs["detections"][2, 1] = np.nan
    obs["detections"][3, 0] = np.inf
    obs["detections"][4] = np.nan  # padding may hold anything
    with pytest.raises(ValueError, match=r"masked-in detection rows \[2, 3\] hold NaN or inf"):
        check_observation(obs, SPEC)


@pytest.mark.parametrize("shape", [(10, 2), (6, 3), (2, 6)])
def test_wrong_detection_shapes_are_named(shape: tuple[int, int]) -> None:
    obs = observation()
    obs["detections"] = np.zeros(shape, np.float32)
    with pytest.raises(ValueError, match=rf"shape \(6, 2\), got float32 \({shape[0]}, {shape[1]}\)"):
        check_observation(obs, SPEC)


def test_a_mask_of_the_wrong_length_is_named() -> None:
    obs = observation()
    obs["mask"] = np.ones(4, np.int8)
    with pytest.raises(ValueError, match=r"shape \(6,\), got int8 \(4,\)"):
        check_observation(obs, SPEC)


@pytest.mark.parametrize("obs", [(np.zeros((6, 2)), np.zeros(6, np.int8)), np.zeros((2, 6)), None])
def test_a_non_mapping_observation_is_named(obs: object) -> None:
    with pytest.raises(
        ValueError,
        match=rf"observation must be a mapping with keys 'detections' and 'mask', got {type(obs).__name__}",
    ):
        check_observation(obs, SPEC)  # type: ignore[arg-type]


def test_a_missing_key_is_named() -> None:
    with pytest.raises(ValueError, match="observation lacks 'mask'"):
        check_observation({"detections": np.zeros((6, 2))}, SPEC)
