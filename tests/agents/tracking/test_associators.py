"""The associator protocol (agents.tracking.associator): every registered associator conforms,
the registry names its errors, and gnn / jpda are the point tracker composed with theirs."""

from __future__ import annotations

import numpy as np
import pytest

from agents import make_agent
from agents.tracking.associator import (
    ASSOCIATOR_DECLARATIONS,
    ASSOCIATOR_REGISTRY,
    Association,
    Associator,
    AssociatorCapability,
    FrameContext,
    associator_declares,
    available_associators,
    make_associator,
    register_associator,
)
from agents.tracking.gated import GatedAssignment
from agents.tracking.second_chance import SecondChance
from agents.tracking.tracker import PointTracker
from track_envs.infra.registry import UnknownArgumentError
from track_envs.streams.constant_velocity import constant_velocity_stream, score_tracker

STREAM = constant_velocity_stream(np.random.default_rng(1), n_targets=8, frames=60, clutter_rate=1.0)


class Recording:
    """Wraps an associator, checks each frame's association against the protocol and that the
    frame context it was given comes back unchanged."""

    def __init__(self, inner: Associator):
        self.inner = inner
        self.frames = 0

    def reset(self, spec, predictor):
        self.inner.reset(spec, predictor)

    def associate(self, frame: FrameContext) -> Association:
        before = {k: np.copy(getattr(frame, k)) for k in ("predicted", "z", "streak", "last")}
        out = self.inner.associate(frame)
        for key, value in before.items():
            np.testing.assert_array_equal(getattr(frame, key), value, err_msg=key)
        n, m = len(frame.predicted), len(frame.z)
        det = out.det_of_track
        assert det.shape == (n,) and det.dtype == np.int64
        assert np.all((det >= -1) & (det < m))
        taken = det[det >= 0]
        if not associator_declares(self.inner, AssociatorCapability.SHARED_DETECTIONS):
            assert len(np.unique(taken)) == len(taken)
        assert out.measurements.shape == frame.predicted.shape
        seen = det >= 0
        assert np.all(np.isfinite(out.measurements[seen]))
        assert out.may_start is None or (out.may_start.shape == (m,) and out.may_start.dtype == np.bool_)
        self.frames += 1
        return out

    def update(self, predictor, state, association, seen):
        return self.inner.update(predictor, state, association, seen)

    def warm_up(self, dim):
        self.inner.warm_up(dim)


@pytest.mark.parametrize("name", available_associators())
def test_every_registered_associator_conforms_and_tracks(name):
    associator = make_associator(name)
    assert isinstance(associator, Associator)
    assert ASSOCIATOR_DECLARATIONS.declared(associator) <= frozenset(AssociatorCapability)
    recording = Recording(associator)
    tracker = PointTracker("kf-cv", associator=recording)
    figures = score_tracker(tracker, STREAM)
    assert recording.frames >= len(STREAM.observations) - 1
    assert figures["mota"] > 0.4 and figures["idf1"] > 0.7, figures
    associator.warm_up(2)


def test_the_builtin_associators_are_registered():
    assert {"gnn", "jpda", "shared-blobs"} <= set(available_associators())


def test_the_registry_names_unknown_associators_and_arguments(monkeypatch):
    with pytest.raises(ValueError, match=r"unknown associator 'nope'; valid names are \['gnn', "):
        make_associator("nope")
    with pytest.raises(
        UnknownArgumentError, match=r"associator 'gnn' has no argument 'gate'; its arguments are"
    ):
        make_associator("gnn", gate=3.0)
    with pytest.raises(ValueError, match=r"assignment must be one of \['greedy', 'hungarian'\], got 'best'"):
        make_associator("gnn", assignment="best")
    monkeypatch.setattr(ASSOCIATOR_REGISTRY, "_factories", dict(ASSOCIATOR_REGISTRY._factories))
    register_associator("greedy-gnn", lambda: GatedAssignment("greedy"))
    assert "greedy-gnn" in available_associators()
    assert make_associator("greedy-gnn").assignment == "greedy"


def test_a_tracker_refuses_what_is_no_associator():
    with pytest.raises(ValueError, match=r"associator must implement the Associator protocol .* lacks"):
        PointTracker("kf-cv", associator=object())  # type: ignore[arg-type]


def test_the_second_chance_is_one_shared_component():
    assert isinstance(make_associator("gnn").second_chance, SecondChance)
    assert isinstance(make_associator("jpda").second_chance, SecondChance)
    with pytest.raises(ValueError, match=r"recovery_cap_noise must be a finite number >= 0, got -1"):
        SecondChance(cap_noise=-1)


@pytest.mark.parametrize(
    ("agent", "kwargs", "associator", "associator_kwargs"),
    [
        ("gnn", {}, "gnn", {}),
        ("gnn", {"assignment": "greedy"}, "gnn", {"assignment": "greedy"}),
        ("gnn", {"blob_extent": 0.004}, "shared-blobs", {"blob_extent": 0.004}),
        ("jpda", {}, "jpda", {}),
        ("jpda", {"merge_model": False}, "jpda", {"merge_model": False}),
    ],
)
def test_gnn_and_jpda_are_the_point_tracker_with_their_associator(
    agent, kwargs, associator, associator_kwargs
):
    built = make_agent(agent, predictor="kf-cv", **kwargs)
    composed = PointTracker("kf-cv", associator=make_associator(associator, **associator_kwargs))
    assert isinstance(built, PointTracker)
    for tracker in (built, composed):
        tracker.reset(STREAM.spec, seed=0)
    for obs in STREAM.observations[:40]:
        a, b = built.act(obs), composed.act(obs)
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
