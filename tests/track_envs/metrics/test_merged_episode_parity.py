"""The compiled metric paths on a merged BeltSorter-v0 episode equal plain reference computations.

A tracker (gnn, kf-ca) follows a dense BeltSorter-v0 stream with touching particles merged into
blobs; every frame's truth, merged detection ids and report are kept. Each metric's streaming
result is then compared with a reference computed here from the definitions, frame by frame, in
plain numpy / Python:

* CLEAR MOT / IDF1: py-motmetrics fed the dense distance matrix of each frame, NaN beyond the
  threshold except the pairs a merged update adds (within ``threshold + spread``, see
  [`track_envs.metrics.merged`][track_envs.metrics.merged]);
* e1 / e2: Python sets of (track, particle) pairs with the merged rules;
* GOSPA: scipy's dense assignment of the ``[C | M]`` problem.
"""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

import track_envs  # noqa: F401
from track_envs.envs.belt_physics import BeltParams
from track_envs.metrics import AssociationErrors, ClearMot, GospaMetric

mm = pytest.importorskip("motmetrics")

FRAMES = 160


@pytest.fixture(scope="module")
def episode():
    """(threshold, frames): each frame ``(truth, merged ids, report)`` of a merged episode."""
    from agents import make_agent

    env = gym.make("BeltSorter-v0", physics=BeltParams(feed_rate=470.0, feed_burstiness=0.0))
    agent = make_agent("gnn", predictor="kf-ca")
    obs, info = env.reset(seed=7)
    agent.reset(env.unwrapped.sensor_spec, seed=7)
    frames = []
    for _ in range(FRAMES):
        report = agent.act(obs)
        frames.append(
            (
                copy.deepcopy(info["truth"]),
                info["detection_ids_merged"].copy(),
                {k: np.array(v) for k, v in report.items()},
            )
        )
        obs, _, _, _, info = env.step(report)
    return float(env.get_wrapper_attr("gospa_c")), frames


def live(truth, report):
    keep = (truth["ids"] >= 0) & truth["visible"]
    rows = report["mask"] == 1
    return (
        truth["ids"][keep],
        np.asarray(truth["positions"], np.float64)[keep],
        report["ids"][rows],
        np.asarray(report["positions"], np.float64)[rows],
        report["detection"][rows],
    )


def test_the_episode_has_merged_updates(episode):
    _, frames = episode
    merged_updates = 0
    for _, merged, report in frames:
        rows = report["detection"][(report["mask"] == 1) & (report["detection"] >= 0)]
        merged_updates += int(np.count_nonzero(merged[rows, 1] >= 0))
    assert merged_updates > 100


def test_clear_mot_equals_motmetrics_on_the_merged_pair_matrix(episode):
    threshold, frames = episode
    ours, acc = ClearMot(threshold), mm.MOTAccumulator(auto_id=True)
    for truth, merged, report in frames:
        ours.update(truth, merged, report)
        oids, x, hids, y, rows = live(truth, report)
        d = cdist(x, y) if len(x) and len(y) else np.zeros((len(x), len(y)))
        possible = d <= threshold
        row_of = {int(o): i for i, o in enumerate(oids)}
        for j, r in enumerate(rows):
            if r < 0 or merged[r, 1] < 0:
                continue
            members = [row_of[int(o)] for o in merged[r] if o >= 0 and int(o) in row_of]
            for i in members:
                spread = max(np.sqrt(((x[i] - x[b]) ** 2).sum()) for b in members)
                possible[i, j] |= threshold < d[i, j] <= threshold + spread
        acc.update(oids, hids, np.where(possible, d, np.nan))
    names = {
        "mota": "mota",
        "motp": "motp",
        "id_switches": "num_switches",
        "idf1": "idf1",
        "num_misses": "num_misses",
        "num_false_positives": "num_false_positives",
        "num_matches": "num_matches",
        "num_objects": "num_objects",
        "num_fragmentations": "num_fragmentations",
        "idtp": "idtp",
        "idfp": "idfp",
        "idfn": "idfn",
    }
    theirs = mm.metrics.create().compute(acc, metrics=list(names.values()), return_dataframe=False)
    mine = ours.compute()
    assert mine["num_objects"] > 20_000
    for key, name in names.items():
        assert mine[key] == pytest.approx(float(theirs[name]), rel=1e-12, abs=1e-12), key


def test_association_errors_equal_python_sets(episode):
    _, frames = episode
    metric = AssociationErrors()
    single, merged_updates, particles = set(), [], set()
    for truth, merged, report in frames:
        metric.update(truth, merged, report)
        particles.update(int(v) for v in merged[merged >= 0])
        for tid, r, on in zip(report["ids"], report["detection"], report["mask"], strict=True):
            if on != 1 or not 0 <= r < len(merged) or merged[r, 0] < 0:
                continue
            members = [int(v) for v in merged[r] if v >= 0]
            if len(members) == 1:
                single.add((int(tid), members[0]))
            else:
                merged_updates.append((int(tid), members))
    pairs = set(single)
    for tid, members in merged_updates:
        if not any((tid, s) in single for s in members):
            pairs.add((tid, members[0]))
    tracks: dict[int, set[int]] = {}
    of_particle: dict[int, set[int]] = {}
    for tid, s in pairs:
        tracks.setdefault(tid, set()).add(s)
        of_particle.setdefault(s, set()).add(tid)
    e1 = sum(len(v) > 1 for v in tracks.values()) / len(tracks)
    e2 = sum(len(of_particle.get(s, ())) != 1 for s in particles) / len(particles)
    out = metric.compute()
    assert (out["n_tracks"], out["n_particles"]) == (len(tracks), len(particles))
    assert out["e1"] == pytest.approx(e1, rel=1e-15) and out["e2"] == pytest.approx(e2, rel=1e-15)


def test_gospa_equals_the_dense_assignment(episode):
    c, frames = episode
    metric, distances = GospaMetric(c), []
    for truth, _, report in frames:
        metric.update(truth, truth["ids"][:0], report)
        _, x, _, y, _ = live(truth, report)
        m, n = len(x), len(y)
        total = c**2 / 2 * (m + n)
        if m and n:
            d2 = np.minimum(cdist(x, y) ** 2, c**2)
            rows, cols = linear_sum_assignment(d2 - c**2)
            total += float((d2[rows, cols] - c**2).sum())
        distances.append(np.sqrt(max(total, 0.0)))
    assert metric.compute()["gospa"] == pytest.approx(np.mean(distances), rel=1e-9)
