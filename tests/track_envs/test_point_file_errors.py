"""Malformed point files: each is read correctly or stopped with one message naming the file, the
row and the value; repairs (repeated detections, rows out of frame order) are warned about with
their count; formats follow the suffix; writes are atomic."""

from __future__ import annotations

import codecs
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from track_envs.infra.atomic import FileWriteError
from track_envs.io import magnitudes
from track_envs.io.csv_parser import DetectionFileError, DetectionFileWarning, TrackFileError
from track_envs.io.detections import (
    read_mot_detections,
    read_wide_detections,
    write_mot_detections,
    write_wide_detections,
)
from track_envs.io.tracks import output_format, read_tracks, track_format, write_tracks
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

REPO = Path(__file__).resolve().parents[2]


def stream(n_frames: int = 12, per: int = 4, seed: int = 0, unit: float = 1.0) -> Detections:
    rng = np.random.default_rng(seed)
    points = rng.uniform(0, 500, (n_frames * per, 2)) * unit
    return Detections(points, np.arange(n_frames + 1) * per)


def tracks(n_frames: int = 12, per: int = 4, seed: int = 0) -> Tracks:
    rng = np.random.default_rng(seed)
    frame = np.repeat(np.arange(n_frames), per)
    ids = np.tile(np.arange(per), n_frames)
    return Tracks(frame, ids, rng.uniform(0, 500, (n_frames * per, 2)), n_frames)


def same(a: Detections, b: Detections) -> bool:
    """The same frames of points (the MOT reader numbers frames from 1)."""
    return np.array_equal(a.points, b.points) and np.array_equal(a.offsets, b.offsets)


def lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def rewrite(path: Path, rows: list[str], end: str = "\n") -> Path:
    path.write_text("\n".join(rows) + end)
    return path


def set_cell(path: Path, row: int, column: int, text: str) -> Path:
    """Put ``text`` in cell (row, column) of ``path`` (row: line number from 1; column from 0)."""
    rows = lines(path)
    cells = rows[row - 1].split(",")
    cells[column] = text
    rows[row - 1] = ",".join(cells)
    return rewrite(path, rows)


# ------------------------------------------------------------------------------ absurd magnitudes


@pytest.mark.parametrize("value", ["1e300", "-1e300", "1e20", "1.7976931348623157e308"])
def test_a_coordinate_no_sensor_gives_is_named_in_a_mot_file(tmp_path: Path, value: str) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    set_cell(path, 7, 2, value)
    with pytest.raises(
        DetectionFileError,
        match=rf"det.txt: row 7, column index 2 \(bb_left\) holds {re.escape(repr(float(value)))}",
    ):
        read_mot_detections(path)


def test_a_coordinate_no_sensor_gives_is_named_in_a_wide_file(tmp_path: Path) -> None:
    path = tmp_path / "det.csv"
    write_wide_detections(path, stream())
    set_cell(path, 4, 3, "1e300")
    with pytest.raises(DetectionFileError, match=r"det.csv: row 4, column index 3 \('y0'\) holds 1e\+300"):
        read_wide_detections(path)


@pytest.mark.parametrize(
    ("name", "fmt", "row", "column"),
    [("gt.txt", "mot", 3, 2), ("gt.csv", "long", 3, 2), ("gt.csv", "wide", 3, 0)],
)
def test_ground_truth_with_an_absurd_coordinate_is_an_error(
    tmp_path: Path, name: str, fmt: str, row: int, column: int
) -> None:
    path = tmp_path / name
    write_tracks(path, tracks(), fmt, truth=True)
    set_cell(path, row, column, "1e300")
    with pytest.raises(DetectionFileError, match=rf"row {row}, column index {column}.* holds 1e\+300"):
        read_tracks(path)


def test_large_data_round_trip_and_the_bound_is_relative_to_the_spread(tmp_path: Path) -> None:
    """Positions of 1e16 with a spread of 1e8 are data (exponent notation reads back exactly); the
    same 1e16 among positions of spread 100 is not."""
    big = stream(unit=1e14)
    write_wide_detections(tmp_path / "big.csv", big)
    assert read_wide_detections(tmp_path / "big.csv").equals(big)
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    set_cell(path, 2, 3, "1e16")
    with pytest.raises(
        DetectionFileError, match=r"row 2, column index 3 \(bb_top\) holds 1e\+16, a position beyond"
    ):
        read_mot_detections(path)
    set_cell(path, 2, 3, "1e9")  # 10^7 spreads: far, but a sensor could (a wrapped counter, say)
    assert read_mot_detections(path).points[1, 1] == 1e9


def test_reference_spread_falls_back_and_ignores_non_finite() -> None:
    ref = magnitudes.reference(np.array([5.0, 5.0, 5.0, 7.0, np.nan, np.inf]))
    assert ref.median == 5.0 and ref.spread == pytest.approx(0.5)  # MAD 0: the mean deviation
    assert not magnitudes.extreme(np.array([5.0, 7.0, 1e11]), ref).any()
    assert magnitudes.extreme(np.array([1e12, np.inf, np.nan]), ref).tolist() == [True, False, False]
    assert not magnitudes.extreme(np.array([3.0]), magnitudes.reference(np.array([3.0, 3.0]))).any()


def test_scale_that_makes_a_coordinate_infinite_is_named(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream(unit=1e150 / 600))
    with pytest.raises(DetectionFileError, match=r"row 1: scale=1e\+300 .*--scale.* must stay finite"):
        read_mot_detections(path, scale=1e300)


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        (0, "1e300", r"row 5, column index 0 holds 1e\+300; the frame must be an integer >= 1 and <= 1e\+08"),
        (1, "1e300", r"row 5, column index 1 holds 1e\+300; the id must be an integer within \+-2\*\*63"),
    ],
)
def test_frames_and_ids_out_of_range_are_named(tmp_path: Path, column: int, value: str, message: str) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    set_cell(path, 5, column, value)
    with pytest.raises(DetectionFileError, match=message):
        read_mot_detections(path)


# ------------------------------------------------------------------------------ rows and columns


def test_a_file_cut_mid_row_is_named(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    rows = lines(path)
    rewrite(path, [*rows[:-1], rows[-1][:25]], end="")  # "12,-1,...,48.32,10" as a full disk leaves it
    with pytest.raises(
        DetectionFileError, match=rf"row {len(rows)} has 4 columns where 10 are expected .*cut off mid-row"
    ):
        read_mot_detections(path)


def test_a_row_missing_a_column_says_so_not_that_a_value_is_wrong(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream(n_frames=500))
    rows = lines(path)
    cells = rows[1500].split(",")
    del cells[4]
    rows[1500] = ",".join(cells)
    rewrite(path, rows)
    with pytest.raises(
        DetectionFileError,
        match=r"row 1501 has 9 columns where 10 are expected \(as the file's other rows have\)$",
    ):
        read_mot_detections(path)


def test_a_long_row_with_a_missing_column_is_named(tmp_path: Path) -> None:
    path = tmp_path / "gt.csv"
    write_tracks(path, tracks(), "long")
    rows = lines(path)
    rows[5] = rows[5].rsplit(",", 1)[0]
    rewrite(path, rows)
    with pytest.raises(
        DetectionFileError, match=r"row 6 has 3 columns where 4 are expected \(as the header names\)"
    ):
        read_tracks(path)


def test_repeated_detections_are_tracked_once_with_a_warning_naming_them(tmp_path: Path) -> None:
    d = stream()
    path = tmp_path / "det.txt"
    write_mot_detections(path, d)
    rows = lines(path)
    rewrite(path, rows[:10] + rows[4:8] + rows[10:])  # rows 5-8 (frame 2) once more, as rows 11-14
    warnings.simplefilter("ignore", DetectionFileWarning)  # the repeats also come out of frame order
    with pytest.warns(
        DetectionFileWarning,
        match=r"4 detections repeat an earlier one of their frame exactly.*"
        r"row 11 repeats row 5, row 12 repeats row 6, row 13 repeats row 7, \.\.\.",
    ):
        back = read_mot_detections(path)
    assert same(back, d)
    with pytest.raises(DetectionFileError, match="4 detections repeat"):
        read_mot_detections(path, duplicates="error")


def test_repeated_pairs_of_a_wide_row_are_named_by_column(tmp_path: Path) -> None:
    path = rewrite(tmp_path / "det.csv", ["frame,count,x0,y0,x1,y1", "0,2,1.5,2.5,1.5,2.5", "1,1,3.0,4.0,,"])
    with pytest.warns(
        DetectionFileWarning,
        match=r"1 detection repeat.*row 2 pair 1 \(column indices 4-5\) repeats row 2 pair 0",
    ):
        back = read_wide_detections(path)
    assert back.counts.tolist() == [1, 1]


def test_distinct_detections_at_one_place_with_different_truth_ids_are_kept(tmp_path: Path) -> None:
    d = Detections(
        np.array([[1.0, 2.0], [1.0, 2.0], [3.0, 4.0]]),
        np.array([0, 2, 3]),
        ids=np.array([4, 5, 4]),
        first_frame=1,
    )
    write_mot_detections(tmp_path / "det.txt", d)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_mot_detections(tmp_path / "det.txt").equals(d)


def test_rows_out_of_frame_order_are_sorted_with_a_warning_giving_the_count(tmp_path: Path) -> None:
    d = stream()
    path = tmp_path / "det.txt"
    write_mot_detections(path, d)
    rows = lines(path)
    rewrite(path, rows[20:] + rows[:20])
    with pytest.warns(
        DetectionFileWarning,
        match=rf"1 row comes after a row of a later frame \(the first: row {len(rows) - 19}\)",
    ):
        assert same(read_mot_detections(path), d)


def test_ground_truth_sorted_by_id_reads_without_a_warning(tmp_path: Path) -> None:
    t = tracks()
    path = tmp_path / "gt.txt"
    write_tracks(path, t, truth=True)
    rows = lines(path)
    rewrite(path, sorted(rows, key=lambda r: int(r.split(",")[1])))  # as MOT16 gt files are
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = read_tracks(path)
    assert np.array_equal(back.positions, t.positions) and np.array_equal(back.ids, t.ids)


def test_ground_truth_repeating_an_id_in_a_frame_names_both_rows(tmp_path: Path) -> None:
    path = tmp_path / "gt.txt"
    write_tracks(path, tracks(), truth=True)
    rows = lines(path)
    rewrite(path, [*rows, rows[6]])
    with pytest.raises(
        DetectionFileError, match=rf"id 2 appears twice in frame 1 \(from 0\) \(rows 7 and {len(rows) + 1}\)"
    ):
        read_tracks(path)


# ------------------------------------------------------------------------------ bytes


def test_binary_files_are_not_text(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    data = path.read_bytes()
    path.write_bytes(data[:100] + b"\x00\x01" + data[100:])
    with pytest.raises(
        DetectionFileError, match=r"det.txt: not a text file \(byte 0x00 at offset 100, row 2"
    ):
        read_mot_detections(path)
    (tmp_path / "x.csv").write_bytes(b"frame,count,x\xb5m\n")
    with pytest.raises(
        DetectionFileError, match=r"x.csv: not a text file \(byte 0xb5 at offset 13, row 1: not UTF-8"
    ):
        read_wide_detections(tmp_path / "x.csv")


@pytest.mark.parametrize("codec", ["utf-16", "utf-8-sig"])
def test_text_with_a_byte_order_mark_is_read(tmp_path: Path, codec: str) -> None:
    d = stream()
    write_mot_detections(tmp_path / "det.txt", d)
    text = (tmp_path / "det.txt").read_text()
    (tmp_path / "bom.txt").write_bytes(text.encode(codec))
    assert (tmp_path / "bom.txt").read_bytes()[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE, b"\xef\xbb")
    assert same(read_mot_detections(tmp_path / "bom.txt"), d)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p.write_text(""), "file is empty"),
        (lambda p: p.write_text("\n\n"), "file is empty"),
        (lambda p: p.mkdir(), "is a directory"),
        (lambda p: None, "no such file"),
    ],
)
def test_empty_missing_and_directory_inputs_are_named(tmp_path: Path, make, message: str) -> None:
    path = tmp_path / "det.txt"
    make(path)
    with pytest.raises(DetectionFileError, match=rf"det.txt: {message}"):
        read_mot_detections(path)


# ------------------------------------------------------------------------------ formats


def test_the_suffix_says_the_format() -> None:
    assert [output_format(n) for n in ("t.txt", "t.csv", "t.zip", "t.dat")] == ["mot", "long", "wide", "mot"]
    assert output_format("t.csv", "wide") == "wide" and output_format("t.dat", "long") == "long"
    with pytest.raises(
        ValueError, match=r"t.csv: a .csv track file is read back as long or wide, not mot; name it \*.txt"
    ):
        output_format("t.csv", "mot")
    with pytest.raises(ValueError, match=r"a .txt track file is read back as mot, not long"):
        output_format("t.txt", "long")


@pytest.mark.parametrize("name", ["t.txt", "t.csv", "t.zip", "t.dat"])
def test_every_default_format_reads_back_as_itself(tmp_path: Path, name: str) -> None:
    t = tracks()
    write_tracks(tmp_path / name, t)
    assert track_format(tmp_path / name) == output_format(name)
    back = read_tracks(tmp_path / name)
    assert np.array_equal(back.positions, t.positions) and np.array_equal(back.frame, t.frame)


def test_mot_rows_under_a_csv_name_are_not_read_as_the_wide_layout(tmp_path: Path) -> None:
    write_tracks(tmp_path / "t.txt", tracks())
    os.replace(tmp_path / "t.txt", tmp_path / "t.csv")  # as an older track run wrote --out t.csv
    with pytest.raises(
        DetectionFileError, match=r"t.csv: a .csv without a header is read as the wide track layout, but"
    ):
        read_tracks(tmp_path / "t.csv")
    assert len(read_tracks(tmp_path / "t.csv", "mot")) == 48


# ------------------------------------------------------------------------------ atomic writes


def test_a_writer_failing_mid_file_keeps_the_old_file(tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    path.write_text("old\n")
    bad = tracks()
    bad.positions[30] = np.inf  # the wide writer refuses it in the second chunk
    import track_envs.io.tracks as track_io

    old_rows = track_io.CHUNK_ROWS
    try:
        track_io.CHUNK_ROWS = 8
        with pytest.raises(ValueError, match="infinity"):
            write_tracks(path, bad, "wide")
    finally:
        track_io.CHUNK_ROWS = old_rows
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv"]


@pytest.mark.parametrize(
    ("name", "fmt"), [("t.txt", "mot"), ("t.csv", "long"), ("t.zip", "wide"), ("d.txt", "det")]
)
def test_a_write_failing_for_want_of_space_keeps_the_old_file_and_names_it(
    tmp_path: Path, name: str, fmt: str
) -> None:
    """A file-size limit (as a full disk) mid-write: FileWriteError naming the file, old file kept."""
    path = tmp_path / name
    path.write_text("old\n")
    code = (
        "import resource, signal, sys\n"
        "import numpy as np\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "from track_envs.io.tracks import write_tracks\n"
        "from track_envs.io.detections import write_mot_detections\n"
        "from track_envs.values.tracks import Tracks\n"
        "from track_envs.values.detections import Detections\n"
        "from track_envs.infra.atomic import FileWriteError\n"
        "n = 20000\n"
        "pos = np.random.default_rng(0).uniform(0, 1, (n, 2))\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (4000, 4000))\n"
        "try:\n"
        "    if sys.argv[2] == 'det':\n"
        "        write_mot_detections(sys.argv[1], Detections(pos, np.arange(n // 4 + 1) * 4))\n"
        "    else:\n"
        "        t = Tracks(np.arange(n) // 4, np.arange(n) % 4, pos, n // 4)\n"
        "        write_tracks(sys.argv[1], t, sys.argv[2])\n"
        "except FileWriteError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(3)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code, str(path), fmt],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        check=False,
    )
    assert result.returncode == 3, result.stderr
    assert result.stdout.startswith(f"{path}: cannot write: File too large (EFBIG)")
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_track_file_error_is_the_base_of_the_readers_errors() -> None:
    assert issubclass(DetectionFileError, TrackFileError) and issubclass(FileWriteError, OSError)


def test_a_frame_number_that_would_make_a_stream_of_empty_frames_is_named(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    write_mot_detections(path, stream())
    set_cell(path, 9, 0, "20000000")
    with pytest.raises(
        DetectionFileError,
        match=r"row 9, column index 0 holds frame 20000000: the file's 48 rows would span 20000000 frames, "
        r"nearly all empty \(at most max\(1e\+06, 1000 per row\) = 1e\+06\)",
    ):
        read_mot_detections(path)
    set_cell(path, 9, 0, "900000")  # a sparse file: within the floor of 10^6 frames
    with pytest.warns(DetectionFileWarning, match="1 row comes after a row of a later frame"):
        assert read_mot_detections(path).n_frames == 900000


def test_one_position_repeated_has_no_relative_bound(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    path.write_text("1,-1,0,0,1,1,0.2\n2,-1,0,0,1e9,1,0.4\n")
    assert read_mot_detections(path).boxes.tolist() == [[0, 0, 1, 1], [0, 0, 1e9, 1]]
