"""jpda's rigid pair (``rigid_merge``): the members of a merged blob keep the offset between their
last estimates, so a long blob cannot swap them.

With the members' predicted offset (``rigid_merge=False``, the model before) both members take the
same innovation while the blob lasts, so the pair's relative motion is extrapolated unobserved: the
kf-ca's relative acceleration (estimation noise of ≈20 µm per frame², a real one of accelerating
particles) grows the offset error quadratically, the tracks drift across each other and each takes
the other's piece when the pair separates (docs/association.md, *The merge model's identity
swaps*). The regression scene: ``touching`` (track_envs.streams.merge_scenes), seed 4, 12
encounters, kf-ca, scored on merged ids (2 mm match distance):

| jpda | e1 | ID switches | HOTA |
|---|---|---|---|
| merge model off | 0 | 37 | 0.7058 |
| merge model, predicted offset (before) | 0.0345 (1 of 29 tracks) | 29 | 0.7123 |
| merge model, rigid pair (now) | 0 | 12 | 0.8191 |
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents import make_agent
from agents.jpda import _kernels
from agents.jpda.agent import JpdaAgent
from agents.tracking.assign import chi2_gate
from track_envs.metrics import AssociationErrors, ClearMot
from track_envs.metrics.base import Metric
from track_envs.metrics.hota_stream import Hota
from track_envs.streams.merge_scenes import MergeScene, merge_scene


def _score(scene: MergeScene, **kwargs: object) -> dict[str, float]:
    agent = make_agent("jpda", predictor="kf-ca", **kwargs)
    metrics: list[Metric] = [AssociationErrors(), ClearMot(threshold=0.002), Hota(threshold=0.002)]
    agent.reset(scene.spec, seed=0)
    for t in range(len(scene)):
        report = agent.act(scene.observation(t))
        for metric in metrics:
            metric.update(scene.truth(t), scene.detection_ids[t], report)
    out: dict[str, float] = {}
    for metric in metrics:
        out.update(metric.compute())
    return out


@pytest.fixture(scope="module")
def touching() -> MergeScene:
    return merge_scene("touching", np.random.default_rng(4), n_events=12)


def test_the_predicted_offset_swaps_a_pair_that_the_rigid_pair_keeps(touching: MergeScene) -> None:
    off = _score(touching, merge_model=False)
    before = _score(touching, rigid_merge=False)
    now = _score(touching)
    assert (off["e1"], off["id_switches"]) == (0.0, 37.0)
    assert off["hota"] == pytest.approx(0.7058, abs=5e-5)
    assert before["e1"] == pytest.approx(1 / 29) and before["id_switches"] == 29.0
    assert before["hota"] == pytest.approx(0.7123, abs=5e-5)
    assert (now["e1"], now["id_switches"]) == (0.0, 12.0)
    assert now["hota"] == pytest.approx(0.8191, abs=5e-5)
    # no worse than without the merge model on any of the figures
    assert now["e1"] <= off["e1"] and now["e2"] <= off["e2"] and now["hota"] >= off["hota"]


def test_without_the_merge_model_rigid_merge_changes_nothing(touching: MergeScene) -> None:
    scene = merge_scene("touching", np.random.default_rng(4), n_events=3)
    reports = []
    for rigid in (False, True):
        agent = make_agent("jpda", predictor="kf-ca", merge_model=False, rigid_merge=rigid)
        agent.reset(scene.spec, seed=0)
        reports.append([agent.act(scene.observation(t)) for t in range(len(scene))])
    for a, b in zip(*reports, strict=True):
        for key in a:
            assert np.array_equal(a[key], b[key], equal_nan=True)


def _frame() -> tuple[np.ndarray, ...]:
    mean = np.array([[0.100, 0.0500], [0.100, 0.0518], [0.100, 0.0560], [0.2, 0.1]])
    cov = np.repeat((8e-5) ** 2 * np.eye(2)[None], 4, axis=0)
    z = np.array([[0.10002, 0.0509], [0.10001, 0.05601], [0.20003, 0.09998]])
    return mean, cov, z


def test_the_predictions_as_anchors_are_the_frame_before() -> None:
    mean, cov, z = _frame()
    args = (chi2_gate(0.999, 2), math.log(4.0), math.log(1e-3), 0.006, (3e-5) ** 2 * np.eye(2), 0.0, 0.0, 12)
    mergeable = np.ones(4, np.bool_)
    want = _kernels.jpda_frame(mean, cov, z, *args, mergeable)
    got = _kernels.jpda_frame_anchored(mean, cov, z, *args, mergeable, mean.copy())
    for a, b in zip(want, got, strict=True):
        assert np.array_equal(a, b)


def test_a_merged_blobs_members_keep_their_anchors_offset() -> None:
    """Only the blob's pseudo-measurements move: ``z_j + ½(a_i − a_k)``; the other tracks and the
    probabilities are those of the predicted anchors."""
    mean, cov, z = _frame()
    args = (chi2_gate(0.999, 2), math.log(4.0), math.log(1e-3), 0.006, (3e-5) ** 2 * np.eye(2), 0.0, 0.0, 12)
    mergeable = np.ones(4, np.bool_)
    anchor = mean.copy()
    anchor[0, 1] -= 4e-4  # the pair was 2.2 mm apart in the last frame, its prediction 1.8 mm
    want = _kernels.jpda_frame(mean, cov, z, *args, mergeable)
    got = _kernels.jpda_frame_anchored(mean, cov, z, *args, mergeable, anchor)
    assert got.merged_with[:2].tolist() == [1, 0] and got.p_seen[:2].min() > 0.99
    np.testing.assert_allclose(got.z_mean[:2], z[0] + 0.5 * (anchor[:2] - anchor[[1, 0]]), atol=1e-9)
    assert np.array_equal(got.p_seen, want.p_seen) and np.array_equal(got.z_mean[2:], want.z_mean[2:])


def test_rigid_merge_must_be_a_bool() -> None:
    with pytest.raises(ValueError, match="rigid_merge must be True or False, got 1"):
        make_agent("jpda", rigid_merge=1)
    assert JpdaAgent().rigid_merge is True
