"""Merged-blob events on a sorter belt (joins, separations, missed pairs): the bounds a tracker
that handles them meets, and gnn breaking them today.

The streams are [`track_envs.streams.merge_events`][track_envs.streams.merge_events] (20 instances of each
event per stream, two streams), the scores
[`track_envs.streams.merge_scoring`][track_envs.streams.merge_scoring] (run by
[`agents.merge_scoring`][agents.merge_scoring]). Bounds, per scenario: >= 95 % of the events resolved (both
particles keep their tracks for the 20 frames after the event, no new track, or for a separation exactly one
new track on the second piece, and no track further than 0.3 mm = 10 σ from its particle), and a lateral kick
(the sideways velocity a track put into its state at the event, beyond its particle's) <= 0.5 mm per frame at
the 95th percentile.

gnn today, on streams 0–2 (60 events per scenario): events resolved, and the kick's median in
mm per frame (``blob_extent`` 4 mm as 2 mm)::

    scenario      kf-ca            kf-ca, 2 mm      kf-cv            kf-cv, 2 mm
    join          2 %    1.49      100 %  0.09      0 %    1.20      100 %  0.14
    separation    98 %   1.47      98 %   1.47      100 %  1.78      100 %  1.78
    missed pair   100 %  0.10      100 %  0.10      100 %  0.13      100 %  0.13

So with either predictor a separation's jump goes into the track's velocity (its next prediction
1.5–1.8 mm sideways past the piece it follows, as on the belt recordings), and without blob
sharing a join starts a new track (kf-ca: 0.8 per event) or swaps the pair (kf-cv: every event).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from agents import make_agent
from agents.merge_scoring import score_agent
from track_envs.streams.merge_events import merge_event_streams
from track_envs.streams.merge_scoring import EventScores, bound_violations, concat_scores

SEEDS = (0, 1)


def merge_event_scores(
    agent_factory: Callable[[], object], seeds: tuple[int, ...] = SEEDS
) -> dict[str, EventScores]:
    """Every scenario's events over the streams of ``seeds``, scored for fresh agents."""
    runs: dict[str, list[EventScores]] = {}
    for seed in seeds:
        for kind, stream in merge_event_streams(np.random.default_rng(seed)).items():
            runs.setdefault(kind, []).append(score_agent(agent_factory, stream, seed))
    return {kind: concat_scores(scores) for kind, scores in runs.items()}


def assert_merge_events_resolved(agent_factory: Callable[[], object], seeds: tuple[int, ...] = SEEDS) -> None:
    """Fail, listing every bound broken, unless ``agent_factory()``'s trackers meet the bounds
    (module docstring) in every scenario."""
    broken = [line for s in merge_event_scores(agent_factory, seeds).values() for line in bound_violations(s)]
    assert not broken, "merge-event bounds broken:\n" + "\n".join(broken)


def _gnn(predictor: str, blob_extent: float) -> Callable[[], object]:
    return lambda: make_agent("gnn", predictor=predictor, blob_extent=blob_extent)


@pytest.fixture(scope="module")
def gnn_ca() -> dict[str, EventScores]:
    return merge_event_scores(_gnn("kf-ca", 0.0))


def test_gnn_breaks_the_bounds(gnn_ca):
    """The issue's configuration: kf-ca, no blob sharing."""
    join, separation, missed = gnn_ca["join"], gnn_ca["separation"], gnn_ca["missed-pair"]
    # a join: a new track in most events, one of the pair's tracks gone or off its particle
    assert join.resolved.mean() <= 0.1
    assert join.new_tracks.mean() >= 0.7
    assert np.median(join.kick) > 1.2e-3
    # a separation: the original track follows a piece, but predicts ≈1.5 mm sideways past it
    assert separation.resolved.mean() >= 0.9
    assert np.median(separation.kick) > 1.2e-3
    # a missed pair is no problem for it (the bounds hold there)
    assert missed.resolved.all() and np.quantile(missed.kick, 0.95) < 0.2e-3
    assert [line.split(":")[0] for s in gnn_ca.values() for line in bound_violations(s)] == [
        "join",
        "join",
        "separation",
    ]
    with pytest.raises(AssertionError, match="merge-event bounds broken"):
        assert_merge_events_resolved(_gnn("kf-ca", 0.0))


@pytest.mark.parametrize(
    ("predictor", "blob_extent", "broken"),
    [
        ("kf-cv", 0.0, {"join", "separation"}),  # joins swap the pair
        ("kf-ca", 2e-3, {"separation"}),  # blob sharing resolves joins, not separations
        ("kf-cv", 2e-3, {"separation"}),
        ("kf-ca", 4e-3, {"separation"}),
    ],
)
def test_no_gnn_configuration_meets_the_bounds(predictor, blob_extent, broken):
    scores = merge_event_scores(_gnn(predictor, blob_extent))
    assert {line.split(":")[0] for s in scores.values() for line in bound_violations(s)} == broken


@pytest.mark.parametrize("predictor", ["kf-ca", "kf-cv"])
def test_jpda_resolves_merge_events(predictor):
    """jpda with its merge model (defaults) meets every bound with either Kalman filter."""
    assert_merge_events_resolved(lambda: make_agent("jpda", predictor=predictor))


def test_jpda_without_its_merge_model_breaks_them_as_gnn_does():
    """The merged-blob events are what resolves joins and separations: without them jpda's
    marginals alone leave a join's blob outside both gates and a separation's pieces outside the
    track's, and the second chance jumps as gnn's does."""
    scores = merge_event_scores(lambda: make_agent("jpda", predictor="kf-ca", merge_model=False))
    assert {line.split(":")[0] for s in scores.values() for line in bound_violations(s)} == {
        "join",
        "separation",
    }
