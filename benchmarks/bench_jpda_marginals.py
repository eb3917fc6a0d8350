"""JPDA marginal association probabilities of a whole frame: ours against brute-force enumeration
per cluster and Stone Soup's exact JPDAwithEHM / JPDAwithEHM2 (if installed).

    python benchmarks/bench_jpda_marginals.py [--tracks 150] [--width 40] [--frames 5] [--repeat 3]

Frames: ``n = --tracks`` targets uniform on a ``2n × --width`` belt (300 × 40 by default),
detected with p_D = 0.9 (measurement noise R = 0.5 I) plus Poisson(n / 10) uniform clutter,
predicted measurement covariances ``S_i = P_i + q I + R`` with ``P_i`` diagonal in [0.3, 1.5];
99% χ² gates. That gives mostly 1–3-track clusters; ``--width 15`` packs them 2.7 times as
densely (clusters up to ~12 tracks). Each side is timed per frame, best of ``--repeat``, summed over frames:

- ours: ``gaussian_log_likelihood`` + gate + ``jpda_marginals`` (clustering included);
- brute force: the same clusters (not timed), every joint event of each cluster enumerated with
  ``itertools.product`` and normalised (the oracle of the tests);
- Stone Soup: ``JPDAwithEHM(2).associate`` with its hypotheses generated beforehand (untimed,
  the Kalman prediction and likelihoods are not part of the figure), i.e. its clustering and EHM
  trees only; and, for reference, its hypothesis generation alone.

Every side's β is compared with ours (max abs difference).
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.jpda.clusters import gate_clusters
from agents.jpda.marginals import jpda_marginals
from agents.jpda.weights import gaussian_log_likelihood
from track_envs.values.types import Gaussian

P_D, P_G, R, Q = 0.9, 0.99, 0.5, 0.1


def make_frame(rng: np.random.Generator, n: int, width: float) -> dict[str, Any]:
    length, n_clutter = 2.0 * n, n / 10
    x = np.column_stack([rng.uniform(0, length, n), rng.uniform(0, width, n)])
    P = np.stack([np.diag(rng.uniform(0.3, 1.5, 2)) for _ in range(n)])
    S = P + (Q + R) * np.eye(2)
    seen = rng.random(n) < P_D
    truth = x[seen] + np.stack([rng.multivariate_normal(np.zeros(2), s) for s in S[seen]])
    clutter = np.column_stack([rng.uniform(0, length, k := rng.poisson(n_clutter)), rng.uniform(0, width, k)])
    z = rng.permutation(np.concatenate([truth, clutter]))
    return {"x": x, "P": P, "S": S, "z": z, "lam": n_clutter / (length * width)}


def ours(f: dict[str, Any]) -> NDArray[np.float64]:
    log_g, d2 = gaussian_log_likelihood(Gaussian(f["x"], f["S"]), f["z"])
    return jpda_marginals(log_g, d2 <= chi2.ppf(P_G, 2), P_D, f["lam"], P_G).beta


def brute_force(
    f: dict[str, Any], log_g: NDArray[np.float64], gate: NDArray[np.bool_]
) -> NDArray[np.float64]:
    n, m = gate.shape
    beta = np.zeros((n, m + 1))
    beta[:, m] = 1.0
    g = np.exp(log_g)
    for tracks, dets in f["clusters"]:
        if len(tracks) == 0 or len(dets) == 0:
            continue
        choices = [[-1, *dets[gate[i, dets]].tolist()] for i in tracks]
        acc = np.zeros((len(tracks), m + 1))
        for event in itertools.product(*choices):
            taken = [j for j in event if j >= 0]
            if len(set(taken)) < len(taken):
                continue
            w = 1.0
            for i, j in zip(tracks, event, strict=True):
                w *= P_D * g[i, j] / f["lam"] if j >= 0 else 1.0 - P_D * P_G
            for k, j in enumerate(event):
                acc[k, j if j >= 0 else m] += w
        beta[tracks] = acc / acc.sum(axis=1, keepdims=True)
    return beta


def stone_soup_setup(f: dict[str, Any], cls: type) -> tuple[Callable[[], Any], Callable[[], Any]]:
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, RandomWalk
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    t0 = datetime.datetime(2020, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=1)
    mm = LinearGaussian(ndim_state=2, mapping=(0, 1), noise_covar=R * np.eye(2))
    hyp = PDAHypothesiser(
        predictor=KalmanPredictor(CombinedLinearGaussianTransitionModel([RandomWalk(Q), RandomWalk(Q)])),
        updater=KalmanUpdater(mm),
        clutter_spatial_density=f["lam"],
        prob_detect=P_D,
        prob_gate=P_G,
    )
    tracks = [
        Track([GaussianState(xi[:, None], Pi, timestamp=t0)]) for xi, Pi in zip(f["x"], f["P"], strict=True)
    ]
    dets = [Detection(zj[:, None], timestamp=t1, measurement_model=mm) for zj in f["z"]]
    associator = cls(hyp)
    hypotheses = associator.generate_hypotheses(set(tracks), set(dets), t1)
    associator.generate_hypotheses = lambda *a, **k: hypotheses  # time the association alone
    index = {id(d): j for j, d in enumerate(dets)}

    def run() -> NDArray[np.float64]:
        out = associator.associate(set(tracks), set(dets), t1)
        beta = np.zeros((len(tracks), len(dets) + 1))
        for i, track in enumerate(tracks):
            for h in out[track]:
                beta[i, index[id(h.measurement)] if h.measurement else len(dets)] = float(h.probability)
        return beta

    def hypothesise() -> Any:
        return cls(hyp).generate_hypotheses(set(tracks), set(dets), t1)

    return run, hypothesise


def best_of(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tracks", type=int, default=150)
    ap.add_argument("--width", type=float, default=40.0)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--no-brute-force", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    try:
        from stonesoup.dataassociator.probability import JPDAwithEHM, JPDAwithEHM2

        ss: list[tuple[str, type]] = [
            ("Stone Soup JPDAwithEHM", JPDAwithEHM),
            ("Stone Soup JPDAwithEHM2", JPDAwithEHM2),
        ]
    except ImportError:
        ss = []
        print("stonesoup not installed: Stone Soup rows skipped")
    times: dict[str, float] = {}
    diffs: dict[str, float] = {}
    sizes: list[int] = []
    n_det = 0
    for _ in range(args.frames):
        f = make_frame(rng, args.tracks, args.width)
        n_det += len(f["z"])
        log_g, d2 = gaussian_log_likelihood(Gaussian(f["x"], f["S"]), f["z"])
        gate = d2 <= chi2.ppf(P_G, 2)
        cl = gate_clusters(gate)
        f["clusters"] = cl.members()
        sizes += cl.n_tracks()[cl.n_tracks() > 0].tolist()
        t, ref = best_of(lambda f=f: ours(f), args.repeat)
        times["ours"] = times.get("ours", 0.0) + t
        rows: list[tuple[str, Callable[[], Any]]] = []
        if not args.no_brute_force:
            rows.append(("brute force", lambda f=f, lg=log_g, g=gate: brute_force(f, lg, g)))
        for name, cls in ss:
            run, hypothesise = stone_soup_setup(f, cls)
            rows.append((name, run))
            if name.endswith("EHM"):
                t, _ = best_of(hypothesise, 1)
                times["Stone Soup hypotheses (not in its row)"] = (
                    times.get("Stone Soup hypotheses (not in its row)", 0.0) + t
                )
        for name, fn in rows:
            t, beta = best_of(fn, args.repeat)
            times[name] = times.get(name, 0.0) + t
            diffs[name] = max(diffs.get(name, 0.0), float(np.abs(beta - ref).max()))
    hist = np.bincount(sizes)
    print(
        f"{args.frames} frames, {args.tracks} tracks, {args.width:g} wide, "
        f"{n_det / args.frames:.0f} detections per frame on average"
    )
    print(
        "tracks per cluster (clusters with >= 1 track): "
        + ", ".join(f"{k}: {c}" for k, c in enumerate(hist) if c)
    )
    print(f"{'method':<42} {'ms/frame':>10} {'× ours':>8} {'max |Δβ|':>10}")
    for name, t in times.items():
        ratio = t / times["ours"]
        d = f"{diffs[name]:.1e}" if name in diffs else "-"
        print(f"{name:<42} {1e3 * t / args.frames:>10.2f} {ratio:>8.1f} {d:>10}")


if __name__ == "__main__":
    main()
