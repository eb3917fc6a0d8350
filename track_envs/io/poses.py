"""Pose files: COCO keypoint results and PoseTrack 2018 JSON in, PoseTrack results out.

**COCO keypoint results** (``format="coco"``): a JSON list of per-pose records
``{"image_id", "category_id", "keypoints": [x, y, v] * K, "score"}`` (optionally ``"scores"``, K
keypoint confidences). Frames are the images: in the order of a given list of image ids
(``frames``, e.g. the ``"images"`` of the PoseTrack ground truth, whose file names are then kept),
else by sorted image id.

**PoseTrack 2018** (``format="posetrack"``; Andriluka et al., "PoseTrack: A Benchmark for Human
Pose Estimation and Tracking", CVPR 2018): one JSON object per video with ``"images"`` (``id``,
``file_name``, optionally ``frame_id`` and ``vid_id``; the frames), ``"annotations"``
(``image_id``, ``track_id``, ``keypoints`` (x, y, v) * K, and for ground truth ``bbox_head``
x, y, w, h; for results ``scores`` and ``score``) and ``"categories"`` (the keypoint names). An
annotation without ``keypoints`` has none labelled.

Keypoint values follow COCO: ``v = 0`` not labelled (its ``x, y`` are ignored and read as 0),
``v = 1`` labelled, not visible, ``v = 2`` labelled and visible. Any other ``v``, a labelled
keypoint at a negative coordinate, a keypoint list of the wrong length or a non-finite value is an
error naming the file, the annotation's index, the keypoint and the value. A keypoint's confidence
is its ``scores`` entry (in [0, 1]) where the record has ``scores``, else 1 for a labelled keypoint;
0 for an unlabelled one.

**Frame order.** The frames of a PoseTrack file (and of a frame list,
[`image_list`][track_envs.io.poses.image_list]) follow the images' ``frame_id`` where they have one, else the
natural order of their ``file_name`` (``…/000009.jpg`` before ``…/000010.jpg``, as PoseTrack numbers its
frames), else their ``id`` — never the order the ``images`` list happens to have: a shuffled list reads as the
ordered one. Some images with a ``frame_id`` and some without, a ``frame_id`` or an image ``id`` listed twice
are errors.

**Errors.** Every problem of a file is a [`PoseFileError`][track_envs.io.PoseFileError] (a
[`TrackFileError`][track_envs.io.TrackFileError], so a ``ValueError``) whose message starts with
the file's path and names the annotation (its index in the file, from 0), the image id, the
keypoint and the value: a file that is not UTF-8 JSON text (binary, another encoding, cut short),
a value of the wrong type (a keypoint written as a string, ``null``, a nested list), a labelled
coordinate that is not finite or beyond ``MAX_COORDINATE`` px (no image is that large), an integer
id beyond 64 bits. Ground truth read with ``ground_truth=True`` is checked completely: every
annotation needs a ``track_id`` and a ``bbox_head``, and no track id may appear twice in one
image. Detections that repeat another of the same image exactly are read, with a
[`PoseFileWarning`][track_envs.io.PoseFileWarning] giving their count.

**Writing** ([`write_posetrack`][track_envs.io.write_posetrack],
[`write_coco_results`][track_envs.io.write_coco_results]; atomically, through
[`track_envs.infra.atomic.atomic_write`][track_envs.io.atomic_write]: a failed write leaves the old file): the
PoseTrack results layout the ``poseval`` tool reads:
per video ``images``, ``annotations`` (``track_id``, ``keypoints`` (x, y, v) with the stream's
visibility, ``0, 0, 0`` for a keypoint not labelled, ``scores``, ``score``) and ``categories``.
poseval requires track ids in 0–999: [`posetrack_track_ids`][track_envs.io.poses.posetrack_track_ids]
renumbers the tracks 0, 1, … by first frame; beyond 1,000 tracks a new track takes the smallest id of a track
that has ended (its last frame before the new one's first), and a video in which more than 1,000 tracks
overlap in time is an error. poseval finds the joints by the names in ``categories`` (PoseTrack's own
17, with ``head_bottom`` and ``head_top`` in COCO's eye slots): results of a COCO file carry
COCO's names unless they are renamed to the ground truth's (``track run --gt`` does).
"""

from __future__ import annotations

import heapq
import itertools
import json
import os
import re
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.atomic import atomic_write
from track_envs.io.csv_parser import TrackFileError
from track_envs.values.keypoints import KEYPOINT_NAMES, SKELETON_EDGES
from track_envs.values.poses import PoseStream

#: Pose file formats.
POSE_FORMATS = ("coco", "posetrack")

#: Track ids the poseval tool accepts: 0 … MAX_TRACK_IDS − 1.
MAX_TRACK_IDS = 1000

#: Largest magnitude of a labelled keypoint coordinate or a head box value, px (no image is larger).
MAX_COORDINATE = 1e12

_INT64 = np.iinfo(np.int64)


class PoseFileError(TrackFileError):
    """A pose file that cannot be read as COCO keypoint results or PoseTrack JSON; the message
    starts with the file's path and names the annotation, the keypoint and the value."""


class PoseFileWarning(UserWarning):
    """A pose file read, with something a user should know (e.g. repeated detections, counted)."""


# ------------------------------------------------------------------------------------------ format


def load_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of ``path``; a [`PoseFileError`][track_envs.io.PoseFileError] naming the file for a file
    that cannot be read, is not UTF-8 text (naming the byte and its position) or not JSON (naming the position
    of the syntax error). A UTF-8 byte-order mark is allowed."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise PoseFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    return _parse_json(raw, path)


def _parse_json(raw: bytes, path: str | os.PathLike[str]) -> Any:
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise PoseFileError(
            f"{path}: not a UTF-8 JSON text file (byte 0x{raw[exc.start]:02x} at position {exc.start}; "
            "a binary file or another encoding)"
        ) from None
    if "\x00" in text:
        at = text.index("\x00")
        raise PoseFileError(f"{path}: not a JSON text file (a NUL byte at position {at}: a binary file)")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        cut = " (the file ends early: cut short?)" if exc.pos >= len(text.rstrip()) else ""
        raise PoseFileError(
            f"{path}: not JSON: {exc.msg} at line {exc.lineno} column {exc.colno}{cut}"
        ) from None
    except RecursionError:
        raise PoseFileError(f"{path}: not a pose file: its JSON nests too deeply") from None


def json_pose_format(data: Any, path: str | os.PathLike[str] = "<json>") -> str:
    """``"coco"`` for a JSON list of pose records, ``"posetrack"`` for an object with ``images``
    and ``annotations``; a ValueError naming what was found otherwise."""
    if isinstance(data, list):
        return "coco"
    if isinstance(data, dict) and "images" in data and "annotations" in data:
        return "posetrack"
    found = sorted(data)[:8] if isinstance(data, dict) else type(data).__name__
    raise PoseFileError(
        f"{path}: neither COCO keypoint results (a list of pose records) nor PoseTrack (an object with "
        f"'images' and 'annotations'); found {found}"
    )


def is_pose_file(path: str | os.PathLike[str], format: str = "auto") -> bool:
    """Whether ``track run`` reads ``path`` as a pose file: ``format`` coco / posetrack, or auto
    and a ``.json`` name."""
    return format in POSE_FORMATS or (format == "auto" and Path(path).suffix.lower() == ".json")


# ------------------------------------------------------------------------------------------ reading


def read_pose_file(
    path: str | os.PathLike[str],
    format: str = "auto",
    *,
    frames: Sequence[int] | None = None,
    file_names: Sequence[str] | None = None,
    num_keypoints: int = len(KEYPOINT_NAMES),
    ground_truth: bool = False,
) -> PoseStream:
    """Read a COCO keypoint results file or a PoseTrack 2018 file (module docstring).

    Args:
        path: The JSON file.
        format: ``"auto"`` (from the JSON's layout), ``"coco"`` or ``"posetrack"``.
        frames: COCO: the image ids in frame order (default: the sorted ids of the records).
        file_names: COCO: one file name per entry of ``frames``.
        num_keypoints: COCO: keypoints per pose ``K`` (17).
        ground_truth: Check the file completely as ground truth to score against: every
            annotation has a ``track_id`` and a ``bbox_head``, no track id twice in one image.

    Raises:
        PoseFileError: a malformed file or value (named, see the module docstring).
    """
    data = load_json(path)
    fmt = json_pose_format(data, path) if format == "auto" else format
    if fmt == "coco":
        if not isinstance(data, list):
            raise PoseFileError(f"{path}: COCO keypoint results must be a JSON list of pose records")
        return _coco(data, path, frames, file_names, num_keypoints, ground_truth)
    if fmt == "posetrack":
        if not isinstance(data, dict):
            raise PoseFileError(
                f"{path}: a PoseTrack file must be a JSON object with 'images' and 'annotations', got a "
                f"{type(data).__name__} (COCO keypoint results are a list: --input-format coco)"
            )
        json_pose_format(data, path)
        return _posetrack(data, path, ground_truth)
    raise ValueError(f"pose format must be one of {['auto', *POSE_FORMATS]}, got {format!r}")


def image_list(path: str | os.PathLike[str]) -> tuple[list[int], list[str] | None]:
    """Frame order from a file: a JSON object with ``"images"`` (a PoseTrack or COCO annotation
    file; in the order of their ``frame_id``, else ``file_name``, else ``id``: module docstring)
    or a text file of image ids, one a line, in the listed order."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        data = load_json(p)
        if not (isinstance(data, dict) and isinstance(data.get("images"), list)):
            raise PoseFileError(f"{path}: a frame list must be a JSON object with 'images'")
        order, names = _frame_order(data["images"], path)
        return order.tolist(), names
    try:
        text = p.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise PoseFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise PoseFileError(
            f"{path}: not a UTF-8 text file of image ids (byte at position {exc.start})"
        ) from None
    ids: list[int] = []
    for line_no, line in enumerate(text.splitlines(), 1):
        if line.strip():
            try:
                value = int(line)
            except ValueError:
                raise PoseFileError(
                    f"{path}, line {line_no}: not an image id: {line.strip()[:40]!r}"
                ) from None
            if not _INT64.min <= value <= _INT64.max:
                raise PoseFileError(f"{path}, line {line_no}: image id {value} is beyond 64 bits")
            ids.append(value)
    return ids, None


def _frame_order(
    images: list[Any], path: str | os.PathLike[str]
) -> tuple[NDArray[np.int64], list[str] | None]:
    """The image ids (and file names, where every image has one) of ``images`` in frame order:
    by ``frame_id``, else by the natural order of ``file_name``, else by ``id`` (module docstring)."""
    ids = np.array([_image_id(im, path, i) for i, im in enumerate(images)], np.int64)
    names = [str(im.get("file_name") or "") for im in images]
    has_frame = np.array(["frame_id" in im for im in images], bool)
    if has_frame.any():
        if not has_frame.all():
            i = int(np.argmin(has_frame))
            raise PoseFileError(
                f"{path}: images[{i}] (id {ids[i]}) has no 'frame_id' while {int(has_frame.sum())} of the "
                f"{len(images)} images have one: the frame order would be ambiguous"
            )
        key = np.array(
            [
                _integer(im["frame_id"], f"{path}: images[{i}] (id {ids[i]}): 'frame_id'")
                for i, im in enumerate(images)
            ],
            np.int64,
        )
        _unique(key, path, "frame_id")
        order = np.argsort(key, kind="stable")
    elif all(names):
        natural = [
            tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", n)) for n in names
        ]
        order = np.array(sorted(range(len(names)), key=natural.__getitem__), np.int64)
    else:
        order = np.argsort(ids, kind="stable")
    _unique(ids, path, "image id")
    return ids[order], [names[i] for i in order.tolist()] if all(names) else None


def _unique(values: NDArray[np.int64], path: str | os.PathLike[str], what: str) -> None:
    ordered = np.sort(values)
    twice = ordered[1:][ordered[1:] == ordered[:-1]]
    if len(twice):
        raise PoseFileError(
            f"{path}: {len(values) - len(np.unique(values))} images repeat the {what} of another "
            f"(e.g. {what} {int(twice[0])} is listed twice); each frame must be listed once"
        )


def _integer(value: Any, where: str) -> int:
    if not _is_int(value):
        raise PoseFileError(f"{where} must be an integer, got {value!r:.80}")
    if not _INT64.min <= value <= _INT64.max:
        raise PoseFileError(f"{where} = {value} is beyond 64 bits")
    return int(value)


def _image_id(image: Any, path: str | os.PathLike[str], i: int) -> int:
    if not isinstance(image, dict):
        raise PoseFileError(f"{path}: images[{i}] must be an object with an integer 'id', got {image!r:.80}")
    return _integer(image.get("id"), f"{path}: images[{i}]: 'id'")


def _is_int(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def _image_ids(records: list[Any], path: str | os.PathLike[str]) -> NDArray[np.int64]:
    for i, r in enumerate(records):
        if not isinstance(r, dict):
            raise PoseFileError(f"{path}: annotation {i} must be an object, got {r!r:.80}")
    values = [r.get("image_id") for r in records]
    if set(map(type, values)) <= {int}:  # the common case, one conversion
        try:
            return np.array(values, np.int64)
        except OverflowError:
            pass
    return np.array(
        [_integer(v, f"{path}: annotation {i}: 'image_id'") for i, v in enumerate(values)], np.int64
    )


def _coco(
    records: list[Any],
    path: str | os.PathLike[str],
    frames: Sequence[int] | None,
    file_names: Sequence[str] | None,
    k: int,
    ground_truth: bool,
) -> PoseStream:
    image_of = _image_ids(records, path)
    order = np.unique(image_of) if frames is None else np.asarray(frames, np.int64)
    if file_names is not None and len(file_names) != len(order):
        raise ValueError(f"file_names must name the {len(order)} frames, got {len(file_names)}")
    names = KEYPOINT_NAMES if k == len(KEYPOINT_NAMES) else tuple(f"keypoint_{j}" for j in range(k))
    return _stream(records, image_of, order, file_names, names, path, None, ground_truth)


def _posetrack(data: dict[str, Any], path: str | os.PathLike[str], ground_truth: bool) -> PoseStream:
    images, annotations = data["images"], data["annotations"]
    if not isinstance(images, list) or not isinstance(annotations, list):
        raise PoseFileError(f"{path}: 'images' and 'annotations' must be lists")
    order, file_names = _frame_order(images, path)
    names = _category_names(data, path)
    image_of = _image_ids(annotations, path)
    video = images[0].get("vid_id") if images else None
    return _stream(
        annotations,
        image_of,
        order,
        file_names,
        names,
        path,
        None if video is None else str(video),
        ground_truth,
    )


def _category_names(data: dict[str, Any], path: str | os.PathLike[str]) -> tuple[str, ...]:
    categories = data.get("categories")
    if not categories:
        return KEYPOINT_NAMES
    if not (isinstance(categories, list) and isinstance(categories[0], dict)):
        raise PoseFileError(f"{path}: 'categories' must be a list of objects")
    names = categories[0].get("keypoints")
    if names is None:
        return KEYPOINT_NAMES
    if not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)):
        raise PoseFileError(
            f"{path}: categories[0]['keypoints'] must be a list of keypoint names, got {names!r:.80}"
        )
    return tuple(names)


def _stream(
    records: list[dict[str, Any]],
    image_of: NDArray[np.int64],
    order: NDArray[np.int64],
    file_names: Sequence[str] | None,
    names: tuple[str, ...],
    path: str | os.PathLike[str],
    video_id: str | None,
    ground_truth: bool = False,
) -> PoseStream:
    """Validate the records' values (batched) and sort them into frames of ``order``."""
    k = len(names)
    _unique(order, path, "image id")
    sorter = np.argsort(order, kind="stable")
    pos = np.searchsorted(order, image_of, sorter=sorter)
    pos = np.minimum(pos, len(order) - 1) if len(order) else pos
    known = (
        (len(order) > 0) & (order[sorter[pos]] == image_of) if len(order) else np.zeros(len(image_of), bool)
    )
    if not np.all(known):
        i = int(np.argmin(known))
        raise PoseFileError(
            f"{path}: annotation {i} has image_id {image_of[i]}, which is not among the {len(order)} frames "
            f"(e.g. {order[:3].tolist()})"
        )
    frame = sorter[pos] if len(order) else np.zeros(0, np.int64)
    where = _Where(path, image_of)
    raw = _keypoint_table(records, names, where)
    x, y, v = raw[:, 0::3], raw[:, 1::3], raw[:, 2::3]
    _check_keypoints(x, y, v, names, where)
    vis = v.astype(np.int8)
    labelled = vis > 0
    kp = np.stack([np.where(labelled, x, 0.0), np.where(labelled, y, 0.0)], axis=-1)
    kscores = np.where(labelled, _keypoint_scores(records, k, names, where), 0.0)
    scores = np.array([_number(r, "score", i, where) for i, r in enumerate(records)], np.float64)
    track_ids = np.array([_track_id(r, i, where, ground_truth) for i, r in enumerate(records)], np.int64)
    heads = np.array([_head_box(r, i, where, ground_truth) for i, r in enumerate(records)], np.float64)
    heads = heads.reshape(-1, 4)
    if ground_truth:
        _check_truth_ids(image_of, track_ids, where)
    else:
        _warn_repeats(image_of, kp, vis, where)
    by_frame = np.argsort(frame, kind="stable")
    offsets = np.concatenate([[0], np.cumsum(np.bincount(frame, minlength=len(order)))]).astype(np.int64)
    return PoseStream(
        keypoints=kp[by_frame],
        visibility=vis[by_frame],
        keypoint_scores=kscores[by_frame],
        offsets=offsets,
        image_ids=order,
        file_names=None if file_names is None else tuple(file_names),
        track_ids=track_ids[by_frame],
        scores=scores[by_frame],
        head_boxes=heads[by_frame],
        keypoint_names=names,
        video_id=video_id,
    )


class _Where:
    """Names an annotation in a message: ``FILE: annotation I (image id N)``."""

    def __init__(self, path: str | os.PathLike[str], image_of: NDArray[np.int64]) -> None:
        self.path, self.image_of = path, image_of

    def __call__(self, i: int) -> str:
        return f"{self.path}: annotation {i} (image id {self.image_of[i]})"


def _check_truth_ids(image_of: NDArray[np.int64], track_ids: NDArray[np.int64], where: _Where) -> None:
    """Ground truth: no track id twice in one image (named, with the count)."""
    pairs = np.stack([image_of, track_ids], axis=1)
    _, first, counts = np.unique(pairs, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        repeats = int(np.sum(counts - 1))
        seen = np.zeros(len(pairs), bool)
        seen[first] = True
        i = int(np.argmin(seen))
        raise PoseFileError(
            f"{where(i)}: track_id {track_ids[i]} appears twice in this image ({repeats} annotations repeat "
            "the image and track id of another); each person is one annotation per image"
        )


def _warn_repeats(image_of: NDArray[np.int64], kp: NDArray, vis: NDArray, where: _Where) -> None:
    """Detections that repeat another of the same image exactly: a warning with their count."""
    if len(image_of) < 2:
        return
    rows = np.concatenate([image_of[:, None].astype(np.float64), kp.reshape(len(kp), -1), vis], axis=1)
    _, first = np.unique(rows, axis=0, return_index=True)
    repeats = len(rows) - len(first)
    if repeats:
        seen = np.zeros(len(rows), bool)
        seen[first] = True
        i = int(np.argmin(seen))
        warnings.warn(
            f"{where(i)} repeats an earlier annotation of the same image exactly: {repeats} poses of "
            f"{len(rows)} are such repeats; each is read, and tracked, as a pose of its own",
            PoseFileWarning,
            stacklevel=4,
        )


def _keypoint_table(
    records: list[dict[str, Any]], names: tuple[str, ...], where: _Where
) -> NDArray[np.float64]:
    k = len(names)
    rows = []
    for i, r in enumerate(records):
        values = r.get("keypoints", [0.0] * (3 * k))
        if not isinstance(values, list) or len(values) != 3 * k:
            got = f"{len(values)} values" if isinstance(values, list) else type(values).__name__
            raise PoseFileError(
                f"{where(i)}: 'keypoints' must hold {3 * k} values ({k} × x, y, v), got {got}"
            )
        rows.append(values)
    if set(map(type, itertools.chain.from_iterable(rows))) <= {int, float}:
        try:
            return np.array(rows, dtype=np.float64).reshape(len(records), 3 * k)
        except OverflowError:  # an integer beyond float range
            pass
    for i, values in enumerate(rows):
        for j, value in enumerate(values):
            if _as_float(value) is None:
                raise PoseFileError(
                    f"{where(i)}: keypoint {names[j // 3]!r}: {'xyv'[j % 3]} is not a number "
                    f"(or beyond any float): {value!r:.80}"
                )
    raise AssertionError("unreachable")  # pragma: no cover


def _as_float(value: Any) -> float | None:
    """``value`` as a float, None for a non-number (a string, null, a list, true / false) or an
    integer beyond float range."""
    if type(value) not in (int, float):
        return None
    try:
        return float(value)
    except OverflowError:
        return None


def _check_keypoints(x: NDArray, y: NDArray, v: NDArray, names: tuple[str, ...], where: _Where) -> None:
    """Raise naming the first bad keypoint value (non-finite, v not 0/1/2, labelled x, y negative or
    beyond MAX_COORDINATE)."""
    big = f"is beyond {MAX_COORDINATE:.0e} px for a labelled keypoint (v > 0): no image is that large"
    checks = (
        (~np.isfinite(v), "v", v, "is not finite"),
        (
            ~np.isin(v, (0, 1, 2)),
            "v",
            v,
            "is not a COCO visibility 0, 1 or 2 (a confidence belongs in 'scores')",
        ),
        ((v > 0) & ~np.isfinite(x), "x", x, "is not finite"),
        ((v > 0) & ~np.isfinite(y), "y", y, "is not finite"),
        ((v > 0) & (x < 0), "x", x, "is negative for a labelled keypoint (v > 0)"),
        ((v > 0) & (y < 0), "y", y, "is negative for a labelled keypoint (v > 0)"),
        ((v > 0) & (x > MAX_COORDINATE), "x", x, big),
        ((v > 0) & (y > MAX_COORDINATE), "y", y, big),
    )
    for bad, what, values, why in checks:
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise PoseFileError(
                f"{where(int(i))}: keypoint {names[j]!r}: {what} = {float(values[i, j])!r} {why}"
            )


def _keypoint_scores(
    records: list[dict[str, Any]], k: int, names: tuple[str, ...], where: _Where
) -> NDArray[np.float64]:
    out = np.ones((len(records), k))
    for i, r in enumerate(records):
        s = r.get("scores")
        if s is None or (isinstance(s, list) and len(s) == 0):
            continue
        if not isinstance(s, list) or len(s) != k:
            raise PoseFileError(f"{where(i)}: 'scores' must hold {k} keypoint confidences, got {s!r:.80}")
        values = [_as_float(value) for value in s]
        if None in values:
            raise PoseFileError(f"{where(i)}: 'scores' must hold numbers, got {s!r:.80}")
        out[i] = values
    bad = ~(np.isfinite(out) & (out >= 0) & (out <= 1))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise PoseFileError(
            f"{where(int(i))}: keypoint {names[j]!r}: score = {float(out[i, j])!r} is not in [0, 1]"
        )
    return out


def _number(r: dict[str, Any], key: str, i: int, where: _Where) -> float:
    value = r.get(key)
    if value is None:
        return float("nan")
    number = _as_float(value)
    if number is None or not np.isfinite(number) or abs(number) > MAX_COORDINATE:
        raise PoseFileError(f"{where(i)}: {key!r} must be a finite number, got {value!r:.80}")
    return number


def _track_id(r: dict[str, Any], i: int, where: _Where, required: bool) -> int:
    value = r.get("track_id")
    if value is None:
        if required:
            raise PoseFileError(
                f"{where(i)} has no 'track_id': every ground-truth pose needs the id of its person"
            )
        return -1
    if not _is_int(value) or not 0 <= value <= _INT64.max:
        raise PoseFileError(f"{where(i)}: 'track_id' must be an integer >= 0 (64 bits), got {value!r:.80}")
    return int(value)


def _head_box(r: dict[str, Any], i: int, where: _Where, required: bool) -> list[float]:
    box = r.get("bbox_head")
    if box is None:
        if required:
            raise PoseFileError(
                f"{where(i)} has no 'bbox_head': the head box x, y, w, h sets the PCKh match radius"
            )
        return [float("nan")] * 4
    values = [_as_float(b) for b in box] if isinstance(box, list) and len(box) == 4 else [None]
    numbers = np.array([np.nan if b is None else b for b in values], np.float64)
    ok = np.all(np.isfinite(numbers)) and np.all(np.abs(numbers) <= MAX_COORDINATE)
    if not ok or numbers[2] < 0 or numbers[3] < 0:
        raise PoseFileError(
            f"{where(i)}: 'bbox_head' must be 4 finite numbers x, y, w >= 0, h >= 0 (at most "
            f"{MAX_COORDINATE:.0e} px), got {box!r:.80}"
        )
    return numbers.tolist()


# ------------------------------------------------------------------------------------------ writing


def posetrack_track_ids(
    frame: NDArray[np.integer], ids: NDArray[np.integer], limit: int = MAX_TRACK_IDS
) -> NDArray[np.int64]:
    """Track ids renumbered into ``0 … limit − 1`` (module docstring): tracks numbered by first
    frame (then by id); past ``limit`` tracks, a new track takes the smallest id of a track whose
    last frame is before its first.

    Args:
        frame: (N,) frame of each row.
        ids: (N,) track id of each row (any integers).
        limit: Number of ids available (poseval: 1,000).

    Raises:
        ValueError: more than ``limit`` tracks overlap in time, naming the frame.
    """
    frame = np.asarray(frame, np.int64)
    ids = np.asarray(ids, np.int64)
    if not len(ids):
        return np.zeros(0, np.int64)
    uniq, inverse = np.unique(ids, return_inverse=True)
    first = np.full(len(uniq), np.iinfo(np.int64).max)
    last = np.full(len(uniq), -1)
    np.minimum.at(first, inverse, frame)
    np.maximum.at(last, inverse, frame)
    new = np.empty(len(uniq), np.int64)
    if len(uniq) <= limit:
        new[np.lexsort((uniq, first))] = np.arange(len(uniq))
        return new[inverse]
    active: list[tuple[int, int]] = []  # (last frame, id) of tracks holding an id
    free: list[int] = []
    next_id = 0
    for t in np.lexsort((uniq, first)).tolist():
        while active and active[0][0] < first[t]:
            heapq.heappush(free, heapq.heappop(active)[1])
        if next_id < limit:
            new[t], next_id = next_id, next_id + 1
        elif free:
            new[t] = heapq.heappop(free)
        else:
            raise ValueError(
                f"more than {limit} tracks overlap in time at frame {first[t]}: PoseTrack results need track "
                f"ids in 0-{limit - 1} and every id is held by a track still running"
            )
        heapq.heappush(active, (int(last[t]), int(new[t])))
    return new[inverse]


def posetrack_json(stream: PoseStream, *, limit: int = MAX_TRACK_IDS) -> dict[str, Any]:
    """The PoseTrack results object of ``stream`` (module docstring); rows without a track id
    (−1) are an error, track ids are renumbered by
    [`posetrack_track_ids`][track_envs.io.poses.posetrack_track_ids]."""
    if np.any(stream.track_ids < 0):
        raise ValueError("every pose of a PoseTrack results file needs a track id; some have none (-1)")
    track = posetrack_track_ids(stream.frame_index(), stream.track_ids, limit)
    names = stream.file_names or tuple(f"{i:06d}.jpg" for i in stream.image_ids.tolist())
    # frame_id orders the frames when the file is read back: the image id where the ids increase
    # with the frames (PoseTrack's own convention), else the frame's index
    increasing = bool(np.all(np.diff(stream.image_ids) > 0))
    images = []
    for t, (image_id, name) in enumerate(zip(stream.image_ids.tolist(), names, strict=True)):
        image: dict[str, Any] = {
            "id": image_id,
            "file_name": name,
            "frame_id": image_id if increasing else t,
            "nframes": stream.n_frames,
        }
        if stream.video_id is not None:
            image["vid_id"] = stream.video_id
        image["is_labeled"] = bool(stream.counts[t] > 0)
        images.append(image)
    present = stream.present
    xyv = np.concatenate([stream.keypoints, stream.visibility[..., None].astype(np.float64)], axis=-1)
    xyv[~present] = 0.0
    image_of = stream.image_ids[stream.frame_index()].tolist()
    annotations = []
    for i in range(len(stream)):
        ann: dict[str, Any] = {
            "id": i,
            "image_id": image_of[i],
            "category_id": 1,
            "track_id": int(track[i]),
            "keypoints": [v if j % 3 != 2 else int(v) for j, v in enumerate(xyv[i].reshape(-1).tolist())],
            "scores": stream.keypoint_scores[i].tolist(),
        }
        if np.isfinite(stream.scores[i]):
            ann["score"] = float(stream.scores[i])
        if np.all(np.isfinite(stream.head_boxes[i])):
            ann["bbox_head"] = stream.head_boxes[i].tolist()
        annotations.append(ann)
    category: dict[str, Any] = {
        "id": 1,
        "name": "person",
        "supercategory": "person",
        "keypoints": list(stream.keypoint_names),
    }
    if stream.num_keypoints == len(KEYPOINT_NAMES):
        category["skeleton"] = (np.asarray(SKELETON_EDGES) + 1).tolist()
    return {"images": images, "annotations": annotations, "categories": [category]}


def coco_results_json(stream: PoseStream) -> list[dict[str, Any]]:
    """``stream`` as COCO keypoint results: one record per pose with ``image_id``,
    ``category_id`` 1, ``keypoints`` (x, y, v), ``scores`` (the keypoint confidences) and
    ``score`` where the pose has one."""
    xyv = np.concatenate([stream.keypoints, stream.visibility[..., None].astype(np.float64)], axis=-1)
    image_of = stream.image_ids[stream.frame_index()].tolist()
    out = []
    for i in range(len(stream)):
        record: dict[str, Any] = {
            "image_id": image_of[i],
            "category_id": 1,
            "keypoints": [v if j % 3 != 2 else int(v) for j, v in enumerate(xyv[i].reshape(-1).tolist())],
            "scores": stream.keypoint_scores[i].tolist(),
        }
        if np.isfinite(stream.scores[i]):
            record["score"] = float(stream.scores[i])
        out.append(record)
    return out


def write_coco_results(path: str | os.PathLike[str], stream: PoseStream) -> None:
    """Write ``stream`` as a COCO keypoint results file
    (`coco_results_json`), atomically.

    Raises:
        FileWriteError: the file could not be written (named, with the cause); the old file is kept.
    """
    data = coco_results_json(stream)
    with atomic_write(path) as f:
        json.dump(data, f)


def write_posetrack(path: str | os.PathLike[str], stream: PoseStream, *, limit: int = MAX_TRACK_IDS) -> None:
    """Write ``stream`` (tracked poses) as a PoseTrack results file
    (`posetrack_json`), atomically.

    Raises:
        FileWriteError: the file could not be written (named, with the cause); the old file is kept.
    """
    data = posetrack_json(stream, limit=limit)
    with atomic_write(path) as f:
        json.dump(data, f)
