"""Tests for ``track_envs.io.wide_tracks``: bit-exact round trips, frame ranges and precise file errors."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.typing import NDArray

from track_envs.io.csv_parser import TrackFileError
from track_envs.io.wide_tracks import load_track_csv, write_track_csv

# Awkward doubles: subnormals, extremes, negative zero, values whose shortest repr uses an exponent.
SPECIAL = [5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -0.0, 0.0, 0.1, 1e-5, 1e16, 1 / 3]


def make_positions(n_frames: int = 40, n_particles: int = 7, seed: int = 0) -> NDArray[np.float64]:
    """Random full-precision positions in metres; particles visible for 10 consecutive frames.

    Particle 0 is always visible and carries the awkward values, the last particle is never visible.
    """
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-0.5, 0.5, (n_frames, n_particles, 2))
    for i in range(1, n_particles - 1):
        first = rng.integers(0, n_frames - 10)
        pos[:first, i] = np.nan
        pos[first + 10 :, i] = np.nan
    pos[:, -1] = np.nan
    pos[: len(SPECIAL), 0, 0] = SPECIAL
    pos[: len(SPECIAL), 0, 1] = SPECIAL[::-1]
    return pos


def assert_bit_equal(actual: NDArray[np.float64], expected: NDArray[np.float64]) -> None:
    """Same shape, NaN in the same cells, and identical bits everywhere else (so -0.0 != 0.0)."""
    assert actual.dtype == np.float64
    assert actual.shape == expected.shape
    nan = np.isnan(expected)
    np.testing.assert_array_equal(np.isnan(actual), nan)
    np.testing.assert_array_equal(actual[~nan].view(np.uint64), expected[~nan].view(np.uint64))


def write_text(path: Path, text: str | bytes) -> Path:
    """Write raw file content and return the path."""
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


# ----------------------------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("name", ["tracks.csv", "tracks.zip", "TRACKS.ZIP"])
def test_round_trip_is_bit_exact(tmp_path: Path, name: str) -> None:
    pos = make_positions()
    path = tmp_path / name
    write_track_csv(path, pos)
    assert_bit_equal(load_track_csv(path), pos)
    assert_bit_equal(load_track_csv(str(path)), pos)


def test_zip_holds_one_member_named_after_the_stem(tmp_path: Path) -> None:
    path = tmp_path / "run1.zip"
    write_track_csv(path, make_positions())
    with zipfile.ZipFile(path) as archive:
        assert archive.namelist() == ["run1.csv"]


@pytest.mark.parametrize("na_rep", ["NaN", "nan", ""])
def test_written_layout(tmp_path: Path, na_rep: str) -> None:
    pos = np.array([[[0.1, -0.0], [np.nan, np.nan]], [[5e-324, 1e300], [1 / 3, 2.5]]])
    path = tmp_path / "t.csv"
    write_track_csv(path, pos, na_rep=na_rep)
    lines = path.read_text().splitlines()
    assert lines == [f"0.1,-0.0,{na_rep},{na_rep}", "5e-324,1e+300,0.3333333333333333,2.5"]
    assert_bit_equal(load_track_csv(path), pos)


@settings(max_examples=30, deadline=None)
@given(
    arrays(
        np.float64,
        st.tuples(st.integers(1, 4), st.integers(1, 3), st.just(2)),
        elements=st.floats(allow_infinity=False, allow_nan=True),
    )
)
def test_round_trip_property(tmp_path_factory: pytest.TempPathFactory, pos: NDArray[np.float64]) -> None:
    pos[np.isnan(pos).any(axis=-1)] = np.nan  # the format has no half-missing pairs
    path = tmp_path_factory.mktemp("prop") / "p.csv"
    write_track_csv(path, pos)
    assert_bit_equal(load_track_csv(path), pos)


def test_loads_empty_cells_nan_crlf_bom_and_trailing_blank_lines(tmp_path: Path) -> None:
    path = write_text(tmp_path / "t.csv", b"\xef\xbb\xbf1.5,2,,\r\n3,4,NaN,nan\r\n\r\n")
    expected = np.array([[[1.5, 2.0], [np.nan, np.nan]], [[3.0, 4.0], [np.nan, np.nan]]])
    assert_bit_equal(load_track_csv(path), expected)


def test_loads_cr_line_endings(tmp_path: Path) -> None:
    path = write_text(tmp_path / "t.csv", b"1,2\r3,4\r")
    assert_bit_equal(load_track_csv(path), np.array([[[1.0, 2.0]], [[3.0, 4.0]]]))


def test_long_text_cell_is_located(tmp_path: Path) -> None:
    path = write_text(tmp_path / "t.csv", "1,2\n3," + "x" * 200_000 + "\n")
    with pytest.raises(TrackFileError, match=r"t\.csv: row 2"):
        load_track_csv(path)


def test_zip_ignores_other_members(tmp_path: Path) -> None:
    path = tmp_path / "t.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("README.txt", "not data")
        archive.writestr("data/tracks.csv", "1,2\n3,4\n")
        archive.writestr("__MACOSX/data/._tracks.csv", "junk")
    assert_bit_equal(load_track_csv(path), np.array([[[1.0, 2.0]], [[3.0, 4.0]]]))


# ---------------------------------------------------------------------------------------------- frame range


@pytest.mark.parametrize("frames", [(0, 40), (0, 1), (5, 17), (39, 40)])
def test_frame_range(tmp_path: Path, frames: tuple[int, int]) -> None:
    pos = make_positions()
    path = tmp_path / "t.csv"
    write_track_csv(path, pos)
    assert_bit_equal(load_track_csv(path, frames=frames), pos[frames[0] : frames[1]])


def test_frame_range_reports_rows_of_the_whole_file(tmp_path: Path) -> None:
    path = write_text(tmp_path / "t.csv", "1,2\n3,4\n5,6\n7,abc\n")
    assert_bit_equal(load_track_csv(path, frames=(1, 3)), np.array([[[3.0, 4.0]], [[5.0, 6.0]]]))
    with pytest.raises(TrackFileError, match="row 4, column index 1 holds text 'abc'"):
        load_track_csv(path, frames=(2, 4))


@pytest.mark.parametrize("frames", [(-1, 3), (3, 3), (4, 2), (0, 5), (5, 6)])
def test_bad_frames_raise_value_error_naming_the_range(tmp_path: Path, frames: tuple[int, int]) -> None:
    path = write_text(tmp_path / "t.csv", "1,2\n3,4\n5,6\n7,8\n")
    with pytest.raises(ValueError, match="frames") as info:
        load_track_csv(path, frames=frames)
    assert not isinstance(info.value, TrackFileError)
    assert "0 <= start < stop <= 4" in str(info.value)
    assert str(frames) in str(info.value)


@pytest.mark.parametrize("frames", [(1,), (1, 2, 3), (0.5, 2), "ab", 3])
def test_malformed_frames_raise_value_error(tmp_path: Path, frames: object) -> None:
    path = write_text(tmp_path / "t.csv", "1,2\n3,4\n")
    with pytest.raises(ValueError, match=r"frames must be a \(start, stop\) pair"):
        load_track_csv(path, frames=frames)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------- bad files


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        # ragged rows, whether the long row is first (pandas would pad silently) or later
        ("1,2,3,4\n5,6,7,8\n1,2\n", "row 3 has 2 fields, expected 4 (as in row 1; ragged rows)"),
        ("1,2\n3,4\n5,6\n1,2,3,4\n", "row 4 has 4 fields, expected 2"),
        ("1,2\n\n3,4\n", "row 2 is blank"),
        ("1,2,3\n4,5,6\n", "3 columns is an odd count; expected (x, y) pairs"),
        ("1,2\n3,4\n5,abc\n", "row 3, column index 1 holds text 'abc', expected a number or NaN"),
        ("1,2,3,4\nNA,1,2,3\n", "row 2, column index 0 holds text 'NA'"),
        ("1,2\n3,1_0\n", "row 2, column index 1 holds text '1_0'"),
        ('1,2\n"3",4\n', "row 2, column index 0 holds text '\"3\"'"),
        ("1,2,3,4\n1,2,,5\n", "row 2, pair 1 (column indices 2-3) has x missing but y set"),
        ("1,2,3,4\n1,NaN,3,4\n", "row 2, pair 0 (column indices 0-1) has y missing but x set"),
        ("1,2\n3,inf\n", "row 2, column index 1 holds inf, an infinity"),
        ("1,2\n-Infinity,4\n", "row 2, column index 0 holds -inf, an infinity"),
        ("", "file is empty"),
        ("\n\n", "file is empty"),
    ],
)
def test_bad_file_message_names_file_and_problem(tmp_path: Path, content: str, problem: str) -> None:
    path = write_text(tmp_path / "bad_tracks.csv", content)
    with pytest.raises(TrackFileError) as info:
        load_track_csv(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert problem in message


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.csv"
    with pytest.raises(TrackFileError, match=r"nowhere\.csv: no such file"):
        load_track_csv(path)


def test_directory_is_not_a_file(tmp_path: Path) -> None:
    with pytest.raises(TrackFileError, match="is a directory"):
        load_track_csv(tmp_path)


@pytest.mark.parametrize(
    ("members", "problem"),
    [
        ({}, "zip archive holds no .csv member; expected exactly one"),
        ({"notes.txt": "x"}, "zip archive holds no .csv member"),
        ({"a.csv": "1,2\n", "b.csv": "1,2\n"}, "zip archive holds 2 .csv members (a.csv, b.csv)"),
    ],
)
def test_zip_without_exactly_one_csv(tmp_path: Path, members: dict[str, str], problem: str) -> None:
    path = tmp_path / "bundle.zip"
    with zipfile.ZipFile(path, "w") as archive:
        for name, text in members.items():
            archive.writestr(name, text)
    with pytest.raises(TrackFileError) as info:
        load_track_csv(path)
    assert str(info.value).startswith(f"{path}: ")
    assert problem in str(info.value)


def test_error_inside_zip_names_archive_and_member(tmp_path: Path) -> None:
    path = tmp_path / "bundle.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("tracks.csv", "1,2\n3,x\n")
    with pytest.raises(TrackFileError, match=r"bundle\.zip \(member tracks\.csv\): row 2, column index 1"):
        load_track_csv(path)


def test_corrupt_zip(tmp_path: Path) -> None:
    path = write_text(tmp_path / "broken.zip", "1,2\n")
    with pytest.raises(TrackFileError, match=r"broken\.zip: not a valid zip archive"):
        load_track_csv(path)


def test_track_file_error_is_a_value_error() -> None:
    assert issubclass(TrackFileError, ValueError)


# ------------------------------------------------------------------------------------------- bad positions


@pytest.mark.parametrize(
    ("positions", "problem"),
    [
        (np.zeros((3, 2)), "shape"),
        (np.zeros((3, 2, 3)), "shape"),
        (np.zeros((0, 2, 2)), "shape"),
        (np.zeros((3, 0, 2)), "shape"),
        (np.array([[[1.0, np.inf]]]), "infinity"),
        (np.array([[[1.0, np.nan]]]), "exactly one NaN (frame 0, particle 0)"),
    ],
)
def test_write_rejects_positions_the_format_cannot_hold(
    tmp_path: Path, positions: NDArray[np.float64], problem: str
) -> None:
    path = tmp_path / "t.csv"
    with pytest.raises(ValueError, match="positions") as info:
        write_track_csv(path, positions)
    assert problem in str(info.value)
    assert not path.exists()


def test_write_rejects_unknown_na_rep(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="na_rep"):
        write_track_csv(tmp_path / "t.csv", np.zeros((1, 1, 2)), na_rep="NA")
