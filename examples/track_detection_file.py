"""Track a detection file outside the gym loop, write the tracks, score them against ground truth.

1. Makes a recording to work on: a BeltSorter-v0 episode with its truth and detections written as
   files (``RecordTracking``: ``det.txt`` / ``gt.txt`` MOTChallenge, ``det.csv`` / ``gt.csv`` wide).
   With your own data, start at step 2 with your file.
2. Reads the detections (``read_detections``), builds the sensor spec the tracker is told
   (``detection_sensor_spec``: dt, the measurement noise, the region), runs a tracker over them
   (``run_agent``) and writes the tracks as MOTChallenge rows (``write_tracks``).
3. Scores them against the ground-truth file (``score_tracks``) — what ``track run ... --gt gt.txt
   --metrics`` prints.

    python examples/track_detection_file.py --out run/ --steps 300
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym

import track_envs  # noqa: F401  (registers the envs)
from agents import make_agent, run_agent, run_episode
from track_envs import detection_sensor_spec
from track_envs.io import read_detections, read_tracks, write_tracks
from track_envs.metrics import score_tracks
from track_envs.wrappers import RecordTracking


def record(folder: Path, steps: int) -> Path:
    """Write one BeltSorter-v0 episode (seed 0; reports of the no-tracking baseline) as files; its folder."""
    env = RecordTracking(gym.make("BeltSorter-v0", max_episode_steps=steps), folder)
    run_episode(env, make_agent("detections"), seed=0)  # the wrapper writes the files at the end
    return folder / "episode-000"


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="run", help="folder for the recording and the tracks")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--predictor", default="kf-ca")
    args = parser.parse_args(argv)
    episode = record(Path(args.out), args.steps)

    detections = read_detections(episode / "det.txt")  # MOTChallenge: box centres, frames from 1
    spec = detection_sensor_spec(detections, dt=0.01, measurement_noise_std=1e-4)  # a 100 Hz camera, 0.1 mm
    tracks = run_agent(make_agent("gnn", predictor=args.predictor), detections, spec, seed=0, progress=True)
    write_tracks(Path(args.out) / "tracks.txt", tracks, "mot")

    metrics, notes = score_tracks(
        tracks, read_tracks(episode / "gt.txt"), threshold=0.005, detections=detections
    )
    print(
        f"{detections.n_frames} frames, {len(detections)} detections -> "
        f"{len(set(tracks.ids.tolist()))} tracks"
    )
    for name in ("mota", "idf1", "id_switches", "e1", "e2", "gospa"):
        if name in metrics:
            print(f"{name:12s} {metrics[name]:.4f}")
    for note in notes:
        print("note:", note)
    return metrics


if __name__ == "__main__":
    main()
