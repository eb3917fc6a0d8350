"""Fuzzed point files: every mutation of a valid MOT, wide or long file is either read (into finite
values a sensor could give) or refused with the project's named error — never another exception;
and ``track run`` on a mutated file exits 0 or with one ``error:`` line, never a traceback, and
leaves no partial ``--out`` file.

Mutations: truncation, byte flips, inserted bytes, duplicated / dropped / shuffled rows, a cell
replaced by an extreme, non-finite or non-numeric value, and re-encodings (latin-1 text, UTF-16
with and without a byte-order mark, a UTF-8 byte-order mark, CRLF line ends). The ``slow``
variants run many more examples (``pytest -m slow tests/track_envs/test_fuzz_point_files.py``).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from track_envs.infra.atomic import FileWriteError
from track_envs.io.csv_parser import TrackFileError
from track_envs.io.detections import (
    read_mot_detections,
    read_wide_detections,
    write_mot_detections,
    write_wide_detections,
)
from track_envs.io.magnitudes import MAX_MAGNITUDE
from track_envs.io.tracks import read_tracks, write_tracks
from track_envs.io.wide_tracks import load_track_csv
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

#: The errors a reader may raise for a bad file.
NAMED = (TrackFileError, FileWriteError)

#: Cell contents a mutation writes in place of a number.
CELLS = [
    "1e300", "-1e300", "1e20", "1.7976931348623157e308", "1e309", "inf", "-inf", "Infinity", "nan", "NaN",
    "", " ", "x", "1,2", "0x10", '"3"', "9223372036854775808", "-9223372036854775809", "1e17", "-0",
    "5e-324", "2.5", "-1", "0", "1e8", "100000001", "1e-320", "\t", "é", "１",
]  # fmt: skip

ROOT = Path(__file__).parent


def _detections(seed: int = 3, n_frames: int = 8, boxes: bool = False) -> Detections:
    rng = np.random.default_rng(seed)
    per = rng.integers(0, 4, n_frames)
    points = rng.uniform(0, 100, (int(per.sum()), 2))
    box = np.concatenate([points - 2, np.full((len(points), 2), 4.0)], axis=1) if boxes else None
    return Detections(points, np.concatenate([[0], np.cumsum(per)]), boxes=box)


def _tracks(seed: int = 4, n_frames: int = 8) -> Tracks:
    rng = np.random.default_rng(seed)
    frame = np.repeat(np.arange(n_frames), 3)
    return Tracks(frame, np.tile([0, 1, 2], n_frames), rng.uniform(0, 100, (len(frame), 2)), n_frames)


def _valid_files(folder: Path) -> dict[str, bytes]:
    """The bytes of each valid file the fuzz mutates, by name."""
    write_mot_detections(folder / "det.txt", _detections())
    write_mot_detections(folder / "box.txt", _detections(boxes=True))
    write_wide_detections(
        folder / "det.csv", Detections(_detections().points, _detections().offsets, times=np.arange(8) * 0.1)
    )
    write_tracks(folder / "gt.txt", _tracks(), truth=True)
    write_tracks(folder / "long.csv", _tracks(), "long")
    write_tracks(folder / "wide.csv", _tracks(), "wide")
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> dict[str, bytes]:
    return _valid_files(tmp_path_factory.mktemp("valid"))


# ------------------------------------------------------------------------------ mutations


def _rows(data: bytes) -> list[bytes]:
    return data.split(b"\n")


@st.composite
def mutated(draw: st.DrawFn, data: bytes) -> bytes:
    """``data`` after one to three mutations."""
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(
            st.sampled_from(["truncate", "flip", "insert", "duplicate", "drop", "shuffle", "cell", "encode"])
        )
        rows = _rows(data)
        if kind == "truncate" and data:
            data = data[: draw(st.integers(0, len(data) - 1))]
        elif kind == "flip" and data:
            at = draw(st.integers(0, len(data) - 1))
            data = data[:at] + bytes([draw(st.integers(0, 255))]) + data[at + 1 :]
        elif kind == "insert":
            at = draw(st.integers(0, len(data)))
            data = data[:at] + draw(st.binary(min_size=1, max_size=4)) + data[at:]
        elif kind == "duplicate" and rows:
            i = draw(st.integers(0, len(rows) - 1))
            j = draw(st.integers(0, len(rows)))
            data = b"\n".join([*rows[:j], rows[i], *rows[j:]])
        elif kind == "drop" and len(rows) > 1:
            i = draw(st.integers(0, len(rows) - 1))
            data = b"\n".join(rows[:i] + rows[i + 1 :])
        elif kind == "shuffle" and len(rows) > 1:
            data = b"\n".join(draw(st.permutations(rows)))
        elif kind == "cell" and rows:
            i = draw(st.integers(0, len(rows) - 1))
            cells = rows[i].split(b",")
            k = draw(st.integers(0, len(cells) - 1))
            cells[k] = draw(st.sampled_from(CELLS)).encode("utf-8")
            rows[i] = b",".join(cells)
            data = b"\n".join(rows)
        elif kind == "encode":
            data = _encode(
                data, draw(st.sampled_from(["latin-1", "utf-16", "utf-16-le", "utf-8-sig", "crlf"]))
            )
    return data


def _encode(data: bytes, how: str) -> bytes:
    text = data.decode("utf-8", errors="replace")
    if how == "crlf":
        return text.replace("\n", "\r\n").encode("utf-8")
    if how == "latin-1":
        return ("µ" + text).encode("latin-1", errors="replace")
    return text.encode(how)


# ------------------------------------------------------------------------------ readers

READERS: dict[str, Callable[[Path], object]] = {
    "det.txt": read_mot_detections,
    "box.txt": lambda p: read_mot_detections(p, scale=0.5, swap_xy=True),
    "det.csv": lambda p: read_wide_detections(p, time_column="time"),
    "gt.txt": read_tracks,
    "long.csv": read_tracks,
    "wide.csv": read_tracks,
}


def _check_read(name: str, path: Path) -> None:
    """Read ``path``: a named error, or values a sensor could give."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = READERS[name](path)
            if name == "wide.csv":
                load_track_csv(path)
    except NAMED as exc:
        event(f"{name}: refused ({type(exc).__name__})")
        return
    event(f"{name}: read")
    values = result.points if isinstance(result, Detections) else result.positions  # type: ignore[attr-defined]
    assert np.isfinite(values).all() and (np.abs(values) <= MAX_MAGNITUDE * 1.0).all()
    if isinstance(result, Tracks):
        _check_frames(name, result, path.read_bytes())


def _check_frames(name: str, tracks: Tracks, data: bytes) -> None:
    """The frames read are the file's: a MOT or long file's up to its last frame with rows, a wide
    file's one per line (a line without a position is a frame without rows)."""
    assert tracks.n_frames >= 1
    if name == "wide.csv":
        assert len(tracks.frame) == 0 or tracks.n_frames > tracks.frame[-1]
        assert tracks.n_frames <= data.count(b"\n") + 1 + data.count(b"\r")
    else:
        assert len(tracks.frame) > 0 and tracks.n_frames == tracks.frame[-1] + 1


def _fuzz_readers(valid: dict[str, bytes], folder: Path, name: str, data: bytes) -> None:
    path = folder / name
    path.write_bytes(data)
    _check_read(name, path)


def fuzz_settings(examples: int) -> Callable[[Callable[..., None]], Callable[..., None]]:
    """Hypothesis settings of the fuzz tests: ``examples`` cases, no deadline, and the health checks
    that a tmp_path fixture and whole-file byte strings would trip switched off."""
    return settings(
        max_examples=examples,
        deadline=None,
        suppress_health_check=[
            HealthCheck.function_scoped_fixture,
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
        ],
    )


def reader_test(examples: int) -> Callable[..., None]:
    @fuzz_settings(examples)
    @given(data=st.data())
    def test(valid: dict[str, bytes], tmp_path: Path, data: st.DataObject) -> None:
        name = data.draw(st.sampled_from(sorted(READERS)))
        _fuzz_readers(valid, tmp_path, name, data.draw(mutated(valid[name])))

    return test


test_every_mutated_point_file_is_read_or_named = reader_test(150)
test_every_mutated_point_file_is_read_or_named_many = pytest.mark.slow(reader_test(3000))


@pytest.mark.parametrize("name", sorted(READERS))
def test_every_valid_file_is_read(valid: dict[str, bytes], tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(valid[name])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        READERS[name](path)


# ------------------------------------------------------------------------------ track run


def _track_run(argv: list[str]) -> tuple[int, str]:
    from track_apps.cli.run import main

    err = io.StringIO()
    with (
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(io.StringIO()),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        code = main(argv)
    return code, err.getvalue()


def run_test(examples: int) -> Callable[..., None]:
    @fuzz_settings(examples)
    @given(data=st.data())
    def test(valid: dict[str, bytes], tmp_path: Path, data: st.DataObject) -> None:
        name = data.draw(st.sampled_from(["det.txt", "box.txt", "det.csv"]))
        path = tmp_path / name
        path.write_bytes(data.draw(mutated(valid[name])))
        out = tmp_path / data.draw(st.sampled_from(["t.txt", "t.csv", "t.zip"]))
        out.unlink(missing_ok=True)
        argv = [str(path), f"--out={out}", "--no-progress", "--agent=gnn", "--dt=0.1"]
        if name == "det.csv":
            argv.append("--time-column=time")
        if data.draw(st.booleans()):
            argv.append("--declared-noise-std=0.5")  # else the run estimates its sensor model
        if data.draw(st.booleans()):
            gt = tmp_path / "gt.txt"
            gt.write_bytes(data.draw(st.sampled_from([valid["gt.txt"], data.draw(mutated(valid["gt.txt"]))])))
            argv += [f"--gt={gt}", "--metrics", "--threshold=5"]
        code, err = _track_run(argv)
        event(f"track run {name}: exit {code}")
        assert "Traceback" not in err
        if code == 0:
            assert out.exists()
        else:
            assert code == 2 and "track run: error: " in err, err
            assert not out.exists(), "a failed run left a partial --out file"
        assert not [p.name for p in tmp_path.iterdir() if p.name.endswith(".part" + out.suffix)]

    return test


test_track_run_on_a_mutated_file_tracks_or_stops_cleanly = run_test(25)
test_track_run_on_a_mutated_file_tracks_or_stops_cleanly_many = pytest.mark.slow(run_test(400))
