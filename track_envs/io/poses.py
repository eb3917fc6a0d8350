"""Pose files: COCO keypoint results and PoseTrack 2018 JSON in, PoseTrack results out.

**COCO keypoint results** (``format="coco"``): a JSON list of per-pose records
``{"image_id", "category_id", "keypoints": [x, y, v] * K, "score"}`` (optionally ``"scores"``, K
keypoint confidences). Frames are the images: in the order of a given list of image ids
(``frames``, e.g. the ``"images"`` of the PoseTrack ground truth, whose file names are then kept),
else by sorted image id.

**PoseTrack 2018** (``format="posetrack"``; Andriluka et al., "PoseTrack: A Benchmark for Human
Pose Estimation and Tracking", CVPR 2018): one JSON object per video with ``"images"`` (``id``,
``file_name``, optionally ``vid_id``; the frames, in the listed order), ``"annotations"``
(``image_id``, ``track_id``, ``keypoints`` (x, y, v) * K, and for ground truth ``bbox_head``
x, y, w, h; for results ``scores`` and ``score``) and ``"categories"`` (the keypoint names). An
annotation without ``keypoints`` has none labelled.

Keypoint values follow COCO: ``v = 0`` not labelled (its ``x, y`` are ignored and read as 0),
``v = 1`` labelled, not visible, ``v = 2`` labelled and visible. Any other ``v``, a labelled
keypoint at a negative coordinate, a keypoint list of the wrong length or a non-finite value is an
error naming the file, the annotation's index, the keypoint and the value. A keypoint's confidence
is its ``scores`` entry (in [0, 1]) where the record has ``scores``, else 1 for a labelled keypoint;
0 for an unlabelled one.

**Writing** (:func:`write_posetrack`): the PoseTrack results layout the ``poseval`` tool reads:
per video ``images``, ``annotations`` (``track_id``, ``keypoints`` (x, y, v) with the stream's
visibility, ``0, 0, 0`` for a keypoint not labelled, ``scores``, ``score``) and ``categories``.
poseval requires track ids in 0–999: :func:`posetrack_track_ids` renumbers the tracks 0, 1, … by
first frame; beyond 1,000 tracks a new track takes the smallest id of a track that has ended
(its last frame before the new one's first), and a video in which more than 1,000 tracks overlap
in time is an error. poseval finds the joints by the names in ``categories`` (PoseTrack's own
17, with ``head_bottom`` and ``head_top`` in COCO's eye slots): results of a COCO file carry
COCO's names unless they are renamed to the ground truth's (``track run --gt`` does).
"""

from __future__ import annotations

import heapq
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.values.keypoints import KEYPOINT_NAMES, SKELETON_EDGES
from track_envs.values.poses import PoseStream

#: Pose file formats.
POSE_FORMATS = ("coco", "posetrack")

#: Track ids the poseval tool accepts: 0 … MAX_TRACK_IDS − 1.
MAX_TRACK_IDS = 1000


# ------------------------------------------------------------------------------------------ format


def load_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of ``path`` (ValueError naming the file and the position of a syntax error)."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not JSON ({exc})") from None


def json_pose_format(data: Any, path: str | os.PathLike[str] = "<json>") -> str:
    """``"coco"`` for a JSON list of pose records, ``"posetrack"`` for an object with ``images``
    and ``annotations``; a ValueError naming what was found otherwise."""
    if isinstance(data, list):
        return "coco"
    if isinstance(data, dict) and "images" in data and "annotations" in data:
        return "posetrack"
    found = sorted(data)[:8] if isinstance(data, dict) else type(data).__name__
    raise ValueError(
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
) -> PoseStream:
    """Read a COCO keypoint results file or a PoseTrack 2018 file (module docstring).

    Args:
        path: The JSON file.
        format: ``"auto"`` (from the JSON's layout), ``"coco"`` or ``"posetrack"``.
        frames: COCO: the image ids in frame order (default: the sorted ids of the records).
        file_names: COCO: one file name per entry of ``frames``.
        num_keypoints: COCO: keypoints per pose ``K`` (17).

    Raises:
        ValueError: a malformed file or value (named, see the module docstring).
    """
    data = load_json(path)
    fmt = json_pose_format(data, path) if format == "auto" else format
    if fmt == "coco":
        if not isinstance(data, list):
            raise ValueError(f"{path}: COCO keypoint results must be a JSON list of pose records")
        return _coco(data, path, frames, file_names, num_keypoints)
    if fmt == "posetrack":
        if not isinstance(data, dict):
            raise ValueError(
                f"{path}: a PoseTrack file must be a JSON object with 'images' and 'annotations', got a "
                f"{type(data).__name__} (COCO keypoint results are a list: --input-format coco)"
            )
        json_pose_format(data, path)
        return _posetrack(data, path)
    raise ValueError(f"pose format must be one of {['auto', *POSE_FORMATS]}, got {format!r}")


def image_list(path: str | os.PathLike[str]) -> tuple[list[int], list[str] | None]:
    """Frame order from a file: a JSON object with ``"images"`` (``id`` and ``file_name``, in
    the listed order: a PoseTrack or COCO annotation file) or a text file of image ids, one a line."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        data = load_json(p)
        if not (isinstance(data, dict) and isinstance(data.get("images"), list)):
            raise ValueError(f"{path}: a frame list must be a JSON object with 'images'")
        images = data["images"]
        ids = [_image_id(im, path, i) for i, im in enumerate(images)]
        names = [str(im.get("file_name", "")) for im in images]
        return ids, names if all(names) else None
    ids = []
    for line_no, line in enumerate(p.read_text().splitlines(), 1):
        if line.strip():
            try:
                ids.append(int(line))
            except ValueError:
                raise ValueError(f"{path}, line {line_no}: not an image id: {line.strip()!r}") from None
    return ids, None


def _image_id(image: Any, path: str | os.PathLike[str], i: int) -> int:
    if not isinstance(image, dict) or not _is_int(image.get("id")):
        raise ValueError(f"{path}: images[{i}] needs an integer 'id', got {image!r:.80}")
    return int(image["id"])


def _is_int(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def _coco(
    records: list[Any],
    path: str | os.PathLike[str],
    frames: Sequence[int] | None,
    file_names: Sequence[str] | None,
    k: int,
) -> PoseStream:
    for i, r in enumerate(records):
        if not isinstance(r, dict) or not _is_int(r.get("image_id")):
            raise ValueError(f"{path}: annotation {i} needs an integer 'image_id', got {r!r:.80}")
    image_of = np.array([int(r["image_id"]) for r in records], dtype=np.int64)
    order = (
        np.array(sorted(set(image_of.tolist())), np.int64) if frames is None else np.asarray(frames, np.int64)
    )
    if file_names is not None and len(file_names) != len(order):
        raise ValueError(f"file_names must name the {len(order)} frames, got {len(file_names)}")
    names = KEYPOINT_NAMES if k == len(KEYPOINT_NAMES) else tuple(f"keypoint_{j}" for j in range(k))
    return _stream(records, image_of, order, file_names, names, path, None)


def _posetrack(data: dict[str, Any], path: str | os.PathLike[str]) -> PoseStream:
    images, annotations = data["images"], data["annotations"]
    if not isinstance(images, list) or not isinstance(annotations, list):
        raise ValueError(f"{path}: 'images' and 'annotations' must be lists")
    order = np.array([_image_id(im, path, i) for i, im in enumerate(images)], np.int64)
    file_names = [str(im.get("file_name", "")) for im in images]
    names = _category_names(data, path)
    for i, a in enumerate(annotations):
        if not isinstance(a, dict) or not _is_int(a.get("image_id")):
            raise ValueError(f"{path}: annotation {i} needs an integer 'image_id', got {a!r:.80}")
    image_of = np.array([int(a["image_id"]) for a in annotations], dtype=np.int64)
    video = images[0].get("vid_id") if images else None
    return _stream(
        annotations,
        image_of,
        order,
        file_names if all(file_names) else None,
        names,
        path,
        None if video is None else str(video),
    )


def _category_names(data: dict[str, Any], path: str | os.PathLike[str]) -> tuple[str, ...]:
    categories = data.get("categories")
    if not categories:
        return KEYPOINT_NAMES
    if not (isinstance(categories, list) and isinstance(categories[0], dict)):
        raise ValueError(f"{path}: 'categories' must be a list of objects")
    names = categories[0].get("keypoints")
    if names is None:
        return KEYPOINT_NAMES
    if not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)):
        raise ValueError(
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
) -> PoseStream:
    """Validate the records' values (batched) and sort them into frames of ``order``."""
    k = len(names)
    if len(set(order.tolist())) != len(order):
        dup = order[np.flatnonzero(np.diff(np.sort(order)) == 0)[0]]
        raise ValueError(f"{path}: image id {dup} is listed twice in the frame order")
    sorter = np.argsort(order, kind="stable")
    pos = np.searchsorted(order, image_of, sorter=sorter)
    pos = np.minimum(pos, len(order) - 1) if len(order) else pos
    known = (
        (len(order) > 0) & (order[sorter[pos]] == image_of) if len(order) else np.zeros(len(image_of), bool)
    )
    if not np.all(known):
        i = int(np.argmin(known))
        raise ValueError(
            f"{path}: annotation {i} has image_id {image_of[i]}, which is not among the {len(order)} frames "
            f"(e.g. {order[:3].tolist()})"
        )
    frame = sorter[pos] if len(order) else np.zeros(0, np.int64)
    raw = _keypoint_table(records, k, path)
    x, y, v = raw[:, 0::3], raw[:, 1::3], raw[:, 2::3]
    _check_keypoints(x, y, v, names, path)
    vis = v.astype(np.int8)
    labelled = vis > 0
    kp = np.stack([np.where(labelled, x, 0.0), np.where(labelled, y, 0.0)], axis=-1)
    kscores = np.where(labelled, _keypoint_scores(records, k, names, path), 0.0)
    scores = np.array([_number(r, "score", i, path) for i, r in enumerate(records)], np.float64)
    track_ids = np.array([_track_id(r, i, path) for i, r in enumerate(records)], np.int64)
    heads = np.array([_head_box(r, i, path) for i, r in enumerate(records)], np.float64).reshape(-1, 4)
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


def _keypoint_table(
    records: list[dict[str, Any]], k: int, path: str | os.PathLike[str]
) -> NDArray[np.float64]:
    rows = []
    for i, r in enumerate(records):
        values = r.get("keypoints", [0.0] * (3 * k))
        if not isinstance(values, list) or len(values) != 3 * k:
            got = f"{len(values)} values" if isinstance(values, list) else type(values).__name__
            raise ValueError(
                f"{path}: annotation {i}: 'keypoints' must hold {3 * k} values ({k} × x, y, v), got {got}"
            )
        rows.append(values)
    try:
        return np.array(rows, dtype=np.float64).reshape(len(records), 3 * k)
    except (TypeError, ValueError):
        for i, values in enumerate(rows):
            for j, value in enumerate(values):
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise ValueError(
                        f"{path}: annotation {i}: keypoint {j // 3} value {'xyv'[j % 3]} is not a "
                        f"number: {value!r}"
                    ) from None
        raise


def _check_keypoints(
    x: NDArray, y: NDArray, v: NDArray, names: tuple[str, ...], path: str | os.PathLike[str]
) -> None:
    """Raise naming the first bad keypoint value (non-finite, v not 0/1/2, negative labelled x, y)."""
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
    )
    for bad, what, values, why in checks:
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise ValueError(
                f"{path}: annotation {i}: keypoint {names[j]!r}: {what} = {float(values[i, j])!r} {why}"
            )


def _keypoint_scores(
    records: list[dict[str, Any]], k: int, names: tuple[str, ...], path: str | os.PathLike[str]
) -> NDArray[np.float64]:
    out = np.ones((len(records), k))
    for i, r in enumerate(records):
        s = r.get("scores")
        if s is None or (isinstance(s, list) and len(s) == 0):
            continue
        if not isinstance(s, list) or len(s) != k:
            raise ValueError(
                f"{path}: annotation {i}: 'scores' must hold {k} keypoint confidences, got {s!r:.80}"
            )
        try:
            out[i] = np.asarray(s, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: annotation {i}: 'scores' must hold numbers, got {s!r:.80}") from None
    bad = ~(np.isfinite(out) & (out >= 0) & (out <= 1))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(
            f"{path}: annotation {i}: keypoint {names[j]!r}: score = {float(out[i, j])!r} is not in [0, 1]"
        )
    return out


def _number(r: dict[str, Any], key: str, i: int, path: str | os.PathLike[str]) -> float:
    value = r.get(key)
    if value is None:
        return float("nan")
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise ValueError(f"{path}: annotation {i}: {key!r} must be a finite number, got {value!r}")
    return float(value)


def _track_id(r: dict[str, Any], i: int, path: str | os.PathLike[str]) -> int:
    value = r.get("track_id")
    if value is None:
        return -1
    if not _is_int(value) or value < 0:
        raise ValueError(f"{path}: annotation {i}: 'track_id' must be an integer >= 0, got {value!r}")
    return int(value)


def _head_box(r: dict[str, Any], i: int, path: str | os.PathLike[str]) -> list[float]:
    box = r.get("bbox_head")
    if box is None:
        return [float("nan")] * 4
    ok = (
        isinstance(box, list)
        and len(box) == 4
        and all(isinstance(b, int | float) and not isinstance(b, bool) for b in box)
    )
    if not ok or not np.all(np.isfinite(box)) or box[2] < 0 or box[3] < 0:
        raise ValueError(
            f"{path}: annotation {i}: 'bbox_head' must be 4 finite numbers x, y, w >= 0, h >= 0, "
            f"got {box!r:.80}"
        )
    return [float(b) for b in box]


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
    (−1) are an error, track ids are renumbered by :func:`posetrack_track_ids`."""
    if np.any(stream.track_ids < 0):
        raise ValueError("every pose of a PoseTrack results file needs a track id; some have none (-1)")
    track = posetrack_track_ids(stream.frame_index(), stream.track_ids, limit)
    names = stream.file_names or tuple(f"{i:06d}.jpg" for i in stream.image_ids.tolist())
    images = []
    for t, (image_id, name) in enumerate(zip(stream.image_ids.tolist(), names, strict=True)):
        image: dict[str, Any] = {
            "id": image_id,
            "file_name": name,
            "frame_id": image_id,
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
    """Write ``stream`` as a COCO keypoint results file (:func:`coco_results_json`)."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(coco_results_json(stream), f)


def write_posetrack(path: str | os.PathLike[str], stream: PoseStream, *, limit: int = MAX_TRACK_IDS) -> None:
    """Write ``stream`` (tracked poses) as a PoseTrack results file (:func:`posetrack_json`)."""
    data = posetrack_json(stream, limit=limit)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f)
