"""Score a MOTChallenge track file with py-motmetrics, beside ``track run``'s own scorer.

``track run ... --out tracks.txt`` writes MOTChallenge rows (frame, id, bb_left, bb_top, bb_width,
bb_height, conf, -1, -1, -1) that py-motmetrics reads as they are::

    python examples/score_with_motmetrics.py GT.txt tracks.txt

prints MOTA, IDF1, MOTP and ID switches from py-motmetrics (IoU >= 0.5, MOTChallenge's rule:
``compare_to_groundtruth(gt, ts, "iou", distth=0.5)``) and, for comparison, the project's own
scores of the same files ([`track_envs.metrics.score_tracks`][track_envs.metrics.score_tracks]), which equal
py-motmetrics'.

py-motmetrics 1.4.0 (the newest release) calls ``np.asfarray`` in its IoU distance, a function
numpy 2.0 removed; the one-line shim below puts it back before motmetrics is imported (it is what
``np.asfarray`` was: ``np.asarray`` with a float dtype). Without py-motmetrics, ``track run ...
--gt GT.txt --metrics`` gives the same figures (and HOTA, equal to TrackEval's).
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

if not hasattr(np, "asfarray"):  # py-motmetrics 1.4.0 calls np.asfarray, removed in numpy 2.0
    np.asfarray = lambda a, dtype=np.float64: np.asarray(a, dtype=dtype)  # type: ignore[attr-defined]  # noqa: NPY201


def motmetrics_scores(gt_path: str, tracks_path: str) -> dict[str, float]:
    """py-motmetrics' MOTA, IDF1, MOTP (1 - IoU) and ID switches of ``tracks_path`` against ``gt_path``."""
    import motmetrics as mm

    with warnings.catch_warnings():  # motmetrics' reader on pandas >= 3
        warnings.simplefilter("ignore", FutureWarning)
        warnings.filterwarnings("ignore", "Operation with tuple is deprecated")
        gt = mm.io.loadtxt(gt_path, fmt="mot15-2D", min_confidence=1)
        ts = mm.io.loadtxt(tracks_path, fmt="mot15-2D")
        acc = mm.utils.compare_to_groundtruth(gt, ts, "iou", distth=0.5)
        summary = mm.metrics.create().compute(acc, metrics=["mota", "idf1", "motp", "num_switches"])
    return {k: float(summary[k].iloc[0]) for k in ("mota", "idf1", "motp", "num_switches")}


#: py-motmetrics' names -> the project's.
OWN_NAMES = {"mota": "mota", "idf1": "idf1", "motp": "motp", "num_switches": "id_switches"}


def own_scores(gt_path: str, tracks_path: str) -> dict[str, float]:
    """The project's scores of the same files, matched by IoU >= 0.5 as above."""
    from track_envs.io import read_tracks
    from track_envs.metrics import score_tracks

    scores, _ = score_tracks(read_tracks(tracks_path), read_tracks(gt_path), threshold=0.5, match="iou")
    return {key: scores[ours] for key, ours in OWN_NAMES.items() if ours in scores}


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gt", help="MOTChallenge ground truth (gt.txt)")
    parser.add_argument("tracks", help="MOTChallenge track file (track run --out tracks.txt)")
    args = parser.parse_args(argv)
    theirs, ours = motmetrics_scores(args.gt, args.tracks), own_scores(args.gt, args.tracks)
    print(f"{'':14s}{'py-motmetrics':>15s}{'track-envs':>12s}")
    for key, value in theirs.items():
        print(f"{key:14s}{value:15.6f}{ours.get(key, float('nan')):12.6f}")
    return {"motmetrics": theirs, "track_envs": ours}


if __name__ == "__main__":
    main()
