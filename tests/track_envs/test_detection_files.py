"""Detection files: MOTChallenge det.txt and the wide per-frame CSV round-trip, read options, named errors."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from track_envs.io.csv_parser import DetectionFileWarning
from track_envs.io.detections import (
    DetectionFileError,
    read_detections,
    read_mot_detections,
    read_wide_detections,
    write_mot_detections,
    write_wide_detections,
)
from track_envs.values.detections import Detections, detection_sensor_spec

# 1e5: within 10^12 spreads of the data (1e16 among values of spread ~0.5 is a coordinate no sensor
# gives, an error: test_magnitude_no_sensor_gives_is_named); large exponents: test_large_data_round_trip
SPECIAL = [5e-324, -0.0, 0.1, 1e-5, 1e5, 1 / 3, -2.5e-300]


def stream(seed: int = 0, n_frames: int = 30, times: bool = True, ids: bool = False) -> Detections:
    """Random frames of 0..6 detections (some empty), awkward doubles in the first frames."""
    rng = np.random.default_rng(seed)
    frames = [rng.uniform(-1, 1, (rng.integers(0, 7), 2)) for _ in range(n_frames)]
    frames[0] = np.array([[a, b] for a, b in zip(SPECIAL, SPECIAL[::-1], strict=True)])
    if n_frames > 3:
        frames[3] = np.zeros((0, 2))
    truth = [rng.integers(-1, 50, len(f)) for f in frames] if ids else None
    return Detections.from_frames(frames, truth, times=np.arange(n_frames) * 0.005 + 1.0 if times else None)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------------- round trips


def test_wide_round_trip_is_bit_exact_with_times(tmp_path: Path) -> None:
    d = stream()
    write_wide_detections(tmp_path / "d.csv", d)
    back = read_wide_detections(tmp_path / "d.csv", time_column="time")
    assert back.equals(d)
    assert back.inferred_dt() == pytest.approx(0.005)


@pytest.mark.parametrize("na_rep", ["NaN", "", "nan"])
def test_wide_round_trip_without_header_or_times(tmp_path: Path, na_rep: str) -> None:
    d = stream(times=False)
    write_wide_detections(tmp_path / "d.csv", d, header=False, na_rep=na_rep)
    assert read_wide_detections(tmp_path / "d.csv").equals(d)


def test_mot_round_trip_is_bit_exact_and_keeps_truth_ids(tmp_path: Path) -> None:
    d = stream(times=False, ids=True)
    d = Detections(d.points, d.offsets, d.ids, first_frame=1)
    write_mot_detections(tmp_path / "det.txt", d)
    back = read_mot_detections(tmp_path / "det.txt", n_frames=d.n_frames)
    assert back.equals(d)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31), st.booleans())
def test_any_stream_round_trips_in_both_formats(tmp_path_factory, seed: int, times: bool) -> None:
    tmp = tmp_path_factory.mktemp("rt")
    d = stream(seed, n_frames=1 + seed % 20, times=times)
    write_wide_detections(tmp / "d.csv", d)
    assert read_wide_detections(tmp / "d.csv", time_column="time" if times else None).equals(d)
    write_mot_detections(tmp / "d.txt", d)
    mot = read_mot_detections(tmp / "d.txt", n_frames=d.n_frames)
    assert np.array_equal(mot.points, d.points) and np.array_equal(mot.offsets, d.offsets)


def test_zip_archives_are_read(tmp_path: Path) -> None:
    d = stream()
    write_wide_detections(tmp_path / "d.csv", d)
    with zipfile.ZipFile(tmp_path / "d.zip", "w") as archive:
        archive.write(tmp_path / "d.csv", "d.csv")
    assert read_detections(tmp_path / "d.zip", time_column="time").equals(d)


# ------------------------------------------------------------------------------------- the layouts


def test_mot_boxes_are_reduced_to_centres_in_frame_order(tmp_path: Path) -> None:
    path = write(
        tmp_path / "det.txt",
        "2,-1,10,20,4,6,0.9,-1,-1,-1\n1,-1,0,0,2,2,0.3,-1,-1,-1\n2,-1,1,1,0,0,0.8,-1,-1,-1\n",
    )
    with pytest.warns(
        DetectionFileWarning, match=r"1 row comes after a row of a later frame \(the first: row 2\)"
    ):
        d = read_mot_detections(path)
    assert d.n_frames == 2 and d.first_frame == 1
    np.testing.assert_array_equal(d.frame(0), [[1, 1]])
    np.testing.assert_array_equal(d.frame(1), [[12, 23], [1, 1]])  # file order within a frame
    np.testing.assert_array_equal(read_mot_detections(path, min_confidence=0.5).counts, [0, 2])
    with pytest.warns(DetectionFileWarning):
        swapped = read_mot_detections(path, swap_xy=True, scale=0.5)
    np.testing.assert_array_equal(swapped.frame(1), [[11.5, 6], [0.5, 0.5]])


def test_mot_six_columns_and_whitespace_padding_are_enough(tmp_path: Path) -> None:
    path = write(tmp_path / "det.txt", "1, -1, 1.0, 2.0, 0, 0\n3, -1, 5, 6, 2, 2\n")
    d = read_mot_detections(path)
    np.testing.assert_array_equal(d.counts, [1, 0, 1])
    np.testing.assert_array_equal(d.points, [[1, 2], [6, 7]])


def test_wide_layout_with_names_gaps_ragged_rows_swap_and_scale(tmp_path: Path) -> None:
    path = write(
        tmp_path / "sorter.csv",
        "t,n,frame,ya,xa,yb,xb\n"
        "0.00,1,10,100,200,NaN,NaN\n"
        "0.02,2,12,110,210,50,60\n"  # frame 11 is missing: an empty frame
        "0.03,0,13\n",  # a short row: no detections
    )
    d = read_wide_detections(
        path,
        frame_column="frame",
        count_column="n",
        time_column="t",
        xy_columns="ya",
        swap_xy=True,
        scale=1e-3,
    )
    assert d.first_frame == 10 and d.n_frames == 4
    np.testing.assert_array_equal(d.counts, [1, 0, 2, 0])
    np.testing.assert_allclose(d.frame(2), [[0.210, 0.110], [0.060, 0.050]])
    assert d.inferred_dt() == pytest.approx(0.01)
    assert np.isnan(d.times[1])


def test_wide_by_index_without_frame_or_count_and_a_trailing_delimiter(tmp_path: Path) -> None:
    path = write(tmp_path / "p.csv", "1;2;3;4;\n5;6;;;\n")
    d = read_wide_detections(path, frame_column=None, count_column=None, delimiter=";")
    np.testing.assert_array_equal(d.counts, [2, 1])
    np.testing.assert_array_equal(d.points, [[1, 2], [3, 4], [5, 6]])
    explicit = read_wide_detections(
        path, frame_column=None, count_column=None, xy_columns=[1, 0], delimiter=";"
    )
    np.testing.assert_array_equal(explicit.points, [[2, 1], [6, 5]])


def test_sensor_spec_is_given_or_inferred() -> None:
    d = stream()
    spec = detection_sensor_spec(d, measurement_noise_std=2e-4)
    assert spec.dt == pytest.approx(0.005) and spec.noise_std == 2e-4
    lo, hi = d.bounds()
    assert np.all(np.asarray(spec.region_low) < lo) and np.all(np.asarray(spec.region_high) > hi)
    assert spec.max_detections == 16 and spec.max_tracks == 16
    given_spec = detection_sensor_spec(d, dt=0.1, region=((-2, -2), (2, 2)), max_detections=7, max_tracks=9)
    assert (given_spec.dt, given_spec.region_low, given_spec.max_detections) == (0.1, (-2.0, -2.0), 7)
    with pytest.raises(ValueError, match=r"dt .* is not given and the stream has no time stamps"):
        detection_sensor_spec(stream(times=False))
    with pytest.raises(ValueError, match="max_detections=3 is below the 7 detections of the fullest frame"):
        detection_sensor_spec(d, max_detections=3)


# ------------------------------------------------------------------------------------ named errors

BAD_WIDE = [
    (
        "frame,count,x0,y0\n0,1,0.5,0.5\n1,1,abc,0.5\n",
        {},
        r"bad\.csv: row 3, column index 2 holds text 'abc'",
    ),
    ("frame,count,x0,y0\n0,1,0.5,inf\n", {}, r"row 2, column index 3 \('y0'\) holds inf, an infinity"),
    (
        "frame,count,x0,y0\n0,1,0.5,\n",
        {},
        r"row 2, column index 3 \('y0'\) is empty but column index 2 \(its pair\) holds",
    ),
    (
        "frame,count,x0,y0\n0,2,0.5,0.5\n",
        {},
        r"row 2, column index 1 \('count'\) says 2 detections but 1 \(x, y\) pairs",
    ),
    (
        "frame,count,x0,y0\n3,1,0.5,0.5\n2,1,0.5,0.5\n",
        {},
        r"row 3, column index 0 \('frame'\) holds frame 2 after frame 3",
    ),
    (
        "frame,count,x0,y0\n0.5,1,0.5,0.5\n",
        {},
        r"row 2, column index 0 \('frame'\) holds 0.5; the frame number must be",
    ),
    (
        "frame,count,x0,y0\n0,-1,NaN,NaN\n",
        {},
        r"row 2, column index 1 \('count'\) holds -1.0; the count must be an integer >= 0",
    ),
    ("frame,count,x0,y0,x1\n0,1,0.5,0.5,1\n", {}, r"3 x, y columns \(column indices 2-4\) is an odd count"),
    (
        "frame,count,x0,y0\n0,1,0.5,0.5\n",
        {"time_column": "time"},
        r"time_column 'time' is not in the header; its columns",
    ),
    (
        "0,1,0.5,0.5\n",
        {"count_column": "count"},
        r"count_column 'count' is a column name, but the file has no header",
    ),
    ("0,1,0.5,0.5\n", {"frame_column": 9}, r"frame_column 9 is outside the file's 4 columns"),
    ("0,1,0.5,0.5\n\n1,1,0.5,0.5\n", {}, r"row 2 is blank"),
    ("frame,count,x0,y0\n", {}, r"has a header but no data rows"),
    ("", {}, r"file is empty"),
]


@pytest.mark.parametrize(("text", "options", "message"), BAD_WIDE)
def test_bad_wide_files_are_named_by_file_row_and_column(
    tmp_path: Path, text: str, options: dict, message: str
) -> None:
    path = write(tmp_path / "bad.csv", text)
    with pytest.raises(DetectionFileError, match=message) as caught:
        read_wide_detections(path, **options)
    assert str(caught.value).startswith(str(path))


BAD_MOT = [
    ("1,-1,0,0,1,1,1\n2,-1,0,x,1,1,1\n", r"row 2, column index 3 holds text 'x'"),
    ("1,-1,0,0,1\n", r"rows have 5 fields; a MOTChallenge row has at least 6"),
    ("0,-1,0,0,1,1,1\n", r"row 1, column index 0 holds 0.0; the frame must be an integer >= 1"),
    ("1,0.5,0,0,1,1,1\n", r"row 1, column index 1 holds 0.5; the id must be an integer"),
    ("1,-1,0,0,1,1,1\n1,-1,0,0,1\n", r"row 2 has 5 columns where 7 are expected"),
    ("1,-1,0,0,inf,1,1\n", r"row 1, column index 4 \(bb_width\) holds inf"),
]


@pytest.mark.parametrize(("text", "message"), BAD_MOT)
def test_bad_mot_files_are_named_by_file_row_and_column(tmp_path: Path, text: str, message: str) -> None:
    path = write(tmp_path / "det.txt", text)
    with pytest.raises(DetectionFileError, match=message) as caught:
        read_mot_detections(path)
    assert str(caught.value).startswith(str(path))


def test_missing_file_and_bad_arguments_are_named(tmp_path: Path) -> None:
    with pytest.raises(DetectionFileError, match=r"nope\.csv: no such file"):
        read_wide_detections(tmp_path / "nope.csv")
    path = write(tmp_path / "d.csv", "0,1,0.5,0.5\n")
    with pytest.raises(ValueError, match="scale must be a finite number > 0, got -1"):
        read_wide_detections(path, scale=-1)
    with pytest.raises(ValueError, match="format must be one of"):
        read_detections(path, "xml")


# ------------------------------------------------------------------------------------ at scale


def small_chunks(monkeypatch: pytest.MonkeyPatch, rows: int) -> None:
    """Every writer formats ``rows`` rows (or cells of a wide row) at a time; tables parse
    ``rows`` cells at a time."""
    import track_envs.io.csv_parser as csv_parser
    import track_envs.io.detections as detections
    import track_envs.io.tracks as tracks
    import track_envs.io.wide_tracks as wide_tracks

    for module in (csv_parser, detections, tracks, wide_tracks):
        monkeypatch.setattr(module, "CHUNK_ROWS", rows, raising=False)
    monkeypatch.setattr(csv_parser, "PARSE_CELLS", rows)


def reference_mot_text(d: Detections, box_size: float = 0.0) -> str:
    """The MOTChallenge rows as one string, row by row (the writer's output before it wrote in chunks)."""
    lines = []
    for t in range(d.n_frames):
        for k in range(d.offsets[t], d.offsets[t + 1]):
            x, y = d.points[k].tolist()
            if d.boxes is not None:
                x, y, w, h = d.boxes[k].tolist()
            else:
                x, y, w, h = (
                    (x - box_size / 2, y - box_size / 2, box_size, box_size) if box_size else (x, y, 0.0, 0.0)
                )
            lines.append(f"{t + 1},{d.ids[k]},{x!r},{y!r},{w!r},{h!r},1.0,-1,-1,-1\n")
    return "".join(lines)


@pytest.mark.parametrize("rows", [1, 3, 1 << 16])
def test_writers_write_in_chunks_the_bytes_of_one_pass(tmp_path, monkeypatch, rows):
    d = stream(seed=4, ids=True)
    write_mot_detections(tmp_path / "one.txt", d, box_size=0.25)
    write_wide_detections(tmp_path / "one.csv", d)
    small_chunks(monkeypatch, rows)
    write_mot_detections(tmp_path / "d.txt", d, box_size=0.25)
    write_wide_detections(tmp_path / "d.csv", d)
    write_wide_detections(tmp_path / "bare.csv", Detections(d.points, d.offsets), header=False, na_rep="")
    assert (
        (tmp_path / "d.txt").read_text() == reference_mot_text(d, 0.25) == (tmp_path / "one.txt").read_text()
    )
    assert (tmp_path / "d.csv").read_bytes() == (tmp_path / "one.csv").read_bytes()
    assert read_wide_detections(tmp_path / "d.csv", time_column="time").equals(
        Detections(d.points, d.offsets, first_frame=0, times=d.times)
    )
    back = read_wide_detections(tmp_path / "bare.csv", header=False)
    np.testing.assert_array_equal(back.points, d.points)
    np.testing.assert_array_equal(back.offsets, d.offsets)
    boxes = read_mot_detections(tmp_path / "d.txt")
    assert boxes.boxes is not None and np.array_equal(boxes.offsets, d.offsets)


def test_tables_parse_in_chunks_the_values_and_errors_of_one_pass(tmp_path, monkeypatch):
    d = stream(seed=5, ids=True)
    write_mot_detections(tmp_path / "d.txt", d, box_size=0.5)
    whole = read_mot_detections(tmp_path / "d.txt")
    lines = (tmp_path / "d.txt").read_text().splitlines()
    lines[40] = lines[40].replace(",1.0,", ",high,", 1)
    write(tmp_path / "bad.txt", "\n".join(lines) + "\n")
    small_chunks(monkeypatch, 7)  # a chunk of a 10-column MOT file is one row
    chunked = read_mot_detections(tmp_path / "d.txt")
    assert chunked.equals(whole) and np.array_equal(chunked.boxes, whole.boxes)
    with pytest.raises(DetectionFileError, match=r"bad.txt: row 41, column index 6 holds text 'high'"):
        read_mot_detections(tmp_path / "bad.txt")


def test_mot_rows_out_of_frame_order_are_grouped_by_frame(tmp_path):
    text = "2,-1,1,1,0,0\n1,-1,5,5,0,0\n2,-1,2,2,0,0\n1,-1,6,6,0,0\n"
    with pytest.warns(
        DetectionFileWarning, match=r"2 rows come after a row of a later frame \(the first: row 2\)"
    ):
        d = read_mot_detections(write(tmp_path / "d.txt", text))
    np.testing.assert_array_equal(d.offsets, [0, 2, 4])
    np.testing.assert_array_equal(d.points, [[5, 5], [6, 6], [1, 1], [2, 2]])


def test_nan_pairs_are_no_detections_and_do_not_size_the_spec(tmp_path):
    path = write(
        tmp_path / "d.csv",
        "frame,count,x0,y0,x1,y1,x2,y2\n0,1,NaN,NaN,0.5,0.5,,\n1,2,0.1,0.1,nan,nan,0.2,0.2\n",
    )
    d = read_wide_detections(path)
    np.testing.assert_array_equal(d.counts, [1, 2])
    assert detection_sensor_spec(d, dt=0.1, max_detections=2).max_detections == 2


def test_wide_tables_parsed_as_one_column_of_cells_give_the_values_and_errors_of_columns(
    tmp_path, monkeypatch
):
    import track_envs.io.csv_parser as csv_parser

    rng = np.random.default_rng(6)
    lines = []
    for _ in range(40):  # ragged rows, empty and NaN cells, a trailing delimiter, awkward doubles
        cells = [
            repr(float(v)) for v in rng.normal(size=rng.integers(1, 90)) * 10.0 ** rng.integers(-300, 300)
        ]
        for k in rng.integers(0, len(cells), 5):
            cells[k] = str(rng.choice(["", "NaN", "nan", " 1.5 ", "-0.0", "5e-324"]))
        lines.append(",".join(cells) + ("," if rng.random() < 0.3 else ""))
    path = write(tmp_path / "wide.csv", "\n".join(lines) + "\n")
    by_columns = csv_parser.read_table(path).values
    monkeypatch.setattr(csv_parser, "WIDE_COLUMNS", 4)
    monkeypatch.setattr(csv_parser, "PARSE_CELLS", 200)  # a few rows a chunk
    by_cells = csv_parser.read_table(path).values
    assert by_cells.shape == by_columns.shape
    assert np.array_equal(by_cells, by_columns, equal_nan=True)
    assert np.array_equal(np.signbit(by_cells), np.signbit(by_columns))
    lines[25] += ",12x"
    with pytest.raises(
        DetectionFileError, match=rf"row 26, column index {lines[25].count(',')} holds text '12x'"
    ):
        csv_parser.read_table(write(tmp_path / "bad.csv", "\n".join(lines)))
