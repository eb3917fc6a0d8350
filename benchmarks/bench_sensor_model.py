"""``track run`` with its sensor model estimated against the best hand-tuned run, on the shipped belt
sample and on TUD-Campus (the MOT15 files py-motmetrics ships); the figures of docs/sensor_model.md.

* belt sample: the true tracks of ``track_envs/data/belt_sample.zip`` (300 frames, dt 0.01 s, metres)
  plus Gaussian noise of std ``--belt-noise`` (default 5e-4 m, seed 0) are the detections, with the
  truth ids; scored against the true tracks, centre distance, threshold 0.005 m;
* TUD-Campus: ``motmetrics/data/TUD-Campus/test.txt`` as detections (box centres), ``gt.txt`` as
  truth, dt 0.04 s; centre distance, threshold 50 px, and boxes (IoU >= 0.5, each track row
  carrying the box of the detection it was updated with).

Hand-tuned grid: predictor kf-ca / kf-cv × declared noise std (5 values) × max_misses 2 / 5 × p_gate
0.99 / 0.999 (40 runs a data set). Estimated: ``estimate_sensor_model`` with the predictor, then one gnn run.

    python benchmarks/bench_sensor_model.py
"""

from __future__ import annotations

import argparse
import itertools
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from agents import make_agent
from agents.files.points import run_agent
from agents.sensor_model import estimate_sensor_model
from track_envs.envs.belt_replay import sample_recording_path
from track_envs.io.detections import read_detections
from track_envs.io.tracks import read_tracks
from track_envs.io.wide_tracks import load_track_csv
from track_envs.metrics.track_scoring import score_tracks
from track_envs.values.detections import Detections, detection_sensor_spec
from track_envs.values.tracks import Tracks


def belt_sample(noise: float) -> tuple[Detections, Tracks]:
    """Detections (truth + noise, seed 0, truth ids) and truth of the shipped belt sample."""
    truth = Tracks.from_wide(load_track_csv(sample_recording_path()))
    points = truth.positions + np.random.default_rng(0).normal(0, noise, truth.positions.shape)
    counts = np.bincount(truth.frame, minlength=truth.n_frames)
    return Detections(points, np.concatenate([[0], np.cumsum(counts)]), truth.ids), truth


def tud_campus() -> tuple[Detections, Tracks]:
    """TUD-Campus test.txt as detections and gt.txt as truth (py-motmetrics' files)."""
    import motmetrics

    folder = Path(str(resources.files(motmetrics))) / "data" / "TUD-Campus"
    return (
        read_detections(folder / "test.txt", "mot"),
        read_tracks(folder / "gt.txt", "mot", min_confidence=1.0),
    )


def mota(
    tracks: Tracks, truth: Tracks, threshold: float, match: str = "distance", rows: str = "all"
) -> tuple[float, float, int]:
    """MOTA, IDF1 and ids of ``tracks`` (``match``: centre ``distance`` within ``threshold``, or ``iou``;
    ``rows``: ``all``, or ``updated`` for the rows updated with a detection only, as ``track run``
    writes box input by default)."""
    if rows == "updated":
        tracks = tracks.updated_rows()
    m, _ = score_tracks(tracks, truth, threshold=threshold, match=match)
    return m["mota"], m["idf1"], len(np.unique(tracks.ids))


def _row(row: tuple) -> str:
    score, idf1, ids, predictor, noise, misses, p_gate = row
    return (
        f"{predictor} noise {noise:g} max_misses {misses} p_gate {p_gate:g} -> MOTA {score:.3f} "
        f"IDF1 {idf1:.3f} ids {ids}"
    )


def compare(
    name: str,
    det: Detections,
    truth: Tracks,
    dt: float,
    threshold: float,
    noises: list[float],
    match: str,
    rows: str = "all",
) -> None:
    print(
        f"## {name}: {len(det)} detections, {det.n_frames} frames, match {match}, threshold {threshold:g}, "
        f"rows {rows}"
    )
    for predictor in ("kf-ca", "kf-cv"):
        spec = detection_sensor_spec(det, dt=dt)
        cal = estimate_sensor_model(det, spec, predictor=predictor)
        tracks = run_agent(
            make_agent("gnn", predictor=predictor, **cal.agent_kwargs()), det, cal.sensor_spec(spec)
        )
        print(
            f"estimated {predictor}: sigma {cal.noise_std:.4g} q {cal.q:.4g} max_misses {cal.max_misses} "
            "-> MOTA %.3f IDF1 %.3f ids %d" % mota(tracks, truth, threshold, match, rows)
        )
    rows = []
    for predictor, noise, misses, p_gate in itertools.product(
        ("kf-ca", "kf-cv"), noises, (2, 5), (0.99, 0.999)
    ):
        spec = detection_sensor_spec(det, dt=dt, measurement_noise_std=noise)
        agent = make_agent("gnn", predictor=predictor, max_misses=misses, p_gate=p_gate)
        rows.append(
            (
                *mota(run_agent(agent, det, spec), truth, threshold, match, rows),
                predictor,
                noise,
                misses,
                p_gate,
            )
        )
    for row in rows:
        print("grid " + _row(row))
    best = max(rows, key=lambda r: r[0])
    print("best hand-tuned: " + _row(best))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--belt-noise", type=float, default=5e-4)
    args = parser.parse_args()
    warnings.simplefilter("ignore", RuntimeWarning)
    s = args.belt_noise
    compare("belt sample", *belt_sample(s), 0.01, 0.005, [s / 4, s / 2, s, 2 * s, 4 * s], "distance")
    compare("TUD-Campus", *tud_campus(), 0.04, 50.0, [1.0, 2.0, 5.0, 10.0, 20.0], "distance")
    compare("TUD-Campus", *tud_campus(), 0.04, 50.0, [1.0, 2.0, 5.0, 10.0, 20.0], "iou")
    compare("TUD-Campus", *tud_campus(), 0.04, 50.0, [1.0, 2.0, 5.0, 10.0, 20.0], "iou", "updated")


if __name__ == "__main__":
    main()
