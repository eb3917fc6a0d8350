"""One-step prediction accuracy with true associations: Kalman CV / CA against the belt LSTMs.

    python benchmarks/bench_lstm_accuracy.py [--steps 1500] [--particle-kind cylinder]

The analogue of Pollithy et al. (2020), Fig. 6: every track of held-out BeltSorter-v0 episodes is
predicted one frame ahead from its own past measurements (no association involved), and each
track's mean prediction error ``mean_t ‖ŷ_t − z_t‖`` is one sample. Added measurement noise
0, 0.1, 0.3 and 0.5 mm.

Fairness: the Kalman process noise ``q`` is tuned per noise level by a grid search on separate
validation episodes (the ``q`` with the lowest mean per-track error), and Kalman tracks start with
the mean entry velocity of the validation tracks as their velocity prior (as the gnn tracker's
learnt flow prior does), with its spread as the prior std. The LSTMs are the shipped weights,
trained on other seeds (see their sidecars).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from predictors import make_predictor
from predictors.belt_lstm.model_stats import spec_of
from predictors.belt_lstm.training import noisy_tracks
from predictors.kalman.predictor import KalmanPredictor
from predictors.training.data import TrackSet, tracks_from_env
from predictors.training.evaluate import one_step_predictions

NOISE_LEVELS = (0.0, 1e-4, 3e-4, 5e-4)
Q_GRID = {"cv": np.logspace(-5, 2, 15), "ca": np.logspace(-3, 4, 15)}
VALIDATION_SEED, TEST_SEED = 1500, 2000


def per_track_errors(predictor: object, data: TrackSet, noise: float, seed: int) -> np.ndarray:
    """Per-track mean one-step errors (m) of ``predictor`` on ``data`` with ``noise`` added."""
    predictor.reset(spec_of(data, noise))  # type: ignore[attr-defined]
    tracks = [t for t in noisy_tracks(data, noise, seed).tracks if len(t) >= 5]
    return one_step_predictions(predictor, tracks).per_track_mean_error()


def entry_velocity(data: TrackSet) -> tuple[np.ndarray, float]:
    """Mean velocity between the first two frames of the tracks, and its largest per-axis std."""
    v = np.array([(t[1] - t[0]) / data.dt for t in data.tracks if len(t) >= 2])
    return v.mean(axis=0), float(v.std(axis=0).max())


def tuned_kalman(model: str, validation: TrackSet, noise: float) -> tuple[float, KalmanPredictor]:
    """The Kalman predictor of the ``q`` that predicts the validation tracks best."""
    velocity, spread = entry_velocity(validation)
    best: tuple[float, float, KalmanPredictor] | None = None
    for q in Q_GRID[model]:
        kf = KalmanPredictor(
            model, q=float(q), initial_velocity=velocity, initial_velocity_std=max(spread, 1e-3)
        )
        score = float(np.mean(per_track_errors(kf, validation, noise, seed=1)))
        if best is None or score < best[0]:
            best = (score, float(q), kf)
    assert best is not None
    return best[1], best[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=1500, help="frames of each held-out episode")
    parser.add_argument("--particle-kind", default="cylinder")
    args = parser.parse_args()
    kw = {"particle_kind": args.particle_kind}
    validation = tracks_from_env("BeltSorter-v0", episodes=1, seed=VALIDATION_SEED, steps=args.steps, **kw)
    test = tracks_from_env("BeltSorter-v0", episodes=1, seed=TEST_SEED, steps=args.steps, **kw)
    print(f"{len(test)} test tracks ({args.particle_kind}, seed {TEST_SEED}); per-track mean error in mm")
    print(f"{'noise mm':>8}  {'predictor':<10} {'mean':>7} {'median':>7} {'p90':>7}  note")
    for noise in NOISE_LEVELS:
        rows = []
        for model in ("cv", "ca"):
            q, kf = tuned_kalman(model, validation, noise)
            rows.append((f"kf-{model}", per_track_errors(kf, test, noise, seed=2), f"q = {q:.3g} (grid)"))
        for name in ("lstm", "nll-lstm", "mc-lstm"):
            predictor = make_predictor(name, particle_kind=args.particle_kind)
            rows.append((name, per_track_errors(predictor, test, noise, seed=2), "shipped weights"))
        for name, err, note in rows:
            e = 1e3 * err
            stats = f"{e.mean():7.3f} {np.median(e):7.3f} {np.quantile(e, 0.9):7.3f}"
            print(f"{1e3 * noise:8.1f}  {name:<10} {stats}  {note}")


if __name__ == "__main__":
    main()
