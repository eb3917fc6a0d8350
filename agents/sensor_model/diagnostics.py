"""Figures of a tracking run that say it went wrong, and the warnings that name them.

Two signs of a tracker told the wrong noise or motion (e.g. settings in metres on a file in pixels):

* **most detections start a track**: ids / detections above ``MAX_ID_RATIO`` — a target seen for
  ``L`` frames should give one id, not ``L``;
* **most tracks are 1–2 frames long**: more than ``MAX_SHORT_SHARE`` of the ids updated with at
  most two detections.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.values.tracks import Tracks

#: Ids per detection above which a run warns.
MAX_ID_RATIO = 0.5
#: Share of ids with at most two detections above which a run warns.
MAX_SHORT_SHARE = 0.5


def count_distinct(values: NDArray[np.integer]) -> int:
    """The number of distinct values, by sorting (``O(n log n)``; ``len(np.unique(values))``
    takes numpy's hash path, seconds for 10^6 distinct ids)."""
    if not len(values):
        return 0
    ordered = np.sort(values, kind="stable")
    return 1 + int(np.count_nonzero(ordered[1:] != ordered[:-1]))


def run_figures(tracks: Tracks, n_detections: int) -> dict[str, float]:
    """``ids``, ``detections``, ``ids_per_detection`` and ``short_track_share`` (the share of ids
    updated with at most two detections; ids counted over the rows with a detection when the
    tracks carry them, else over every row)."""
    rows = tracks.detection >= 0 if tracks.detection is not None else np.ones(len(tracks), bool)
    ids, counts = np.unique(tracks.ids[rows], return_counts=True)
    n_ids = count_distinct(tracks.ids)
    return {
        "ids": float(n_ids),
        "detections": float(n_detections),
        "ids_per_detection": n_ids / n_detections if n_detections else 0.0,
        "short_track_share": float(np.mean(counts <= 2)) if len(ids) else 0.0,
    }


def run_warnings(tracks: Tracks, n_detections: int) -> list[str]:
    """The warnings of a run whose figures (`run_figures`) look
    wrong, each naming its figure."""
    f = run_figures(tracks, n_detections)
    out = []
    if f["ids_per_detection"] > MAX_ID_RATIO:
        out.append(
            f"most detections start a track: {int(f['ids'])} ids for {int(f['detections'])} detections "
            f"(ids/detections = {f['ids_per_detection']:.2f} > {MAX_ID_RATIO}); the measurement or motion "
            "noise the tracker assumes is likely far too small for these data"
        )
    if f["short_track_share"] > MAX_SHORT_SHARE:
        out.append(
            f"most tracks are 1-2 frames long: {100 * f['short_track_share']:.0f}% of the ids have at most "
            f"two detections (> {100 * MAX_SHORT_SHARE:.0f}%)"
        )
    return out
