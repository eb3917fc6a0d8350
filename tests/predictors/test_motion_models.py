"""predictors.motion_models: one listing of every motion model with its kind and its agents."""

from __future__ import annotations

import pytest

from agents import AGENTS, available_agents
from agents.base import agent_traits
from predictors import KINDS, available_predictors, motion_models
from predictors.displacement import DISPLACEMENT_MODELS
from predictors.pose import POSE_MOTIONS


def test_every_registered_model_is_listed_once_with_its_kind():
    listed = [(m.kind, m.name) for m in motion_models()]
    assert len(listed) == len(set(listed))
    assert [n for k, n in listed if k == "gaussian"] == available_predictors()
    assert [n for k, n in listed if k == "displacement"] == DISPLACEMENT_MODELS.names()
    assert [n for k, n in listed if k == "pose"] == POSE_MOTIONS.names()
    assert {k for k, _ in listed} == set(KINDS) == {"gaussian", "displacement", "pose"}


def test_the_agents_of_each_kind_are_registered_and_declare_what_they_take():
    models = motion_models()
    assert all(set(m.agents) <= set(available_agents()) and m.agents for m in models)
    takers = tuple(a for a in available_agents() if agent_traits(AGENTS.factory(a)).takes_predictor)
    assert {m.agents for m in motion_models("gaussian")} == {takers}
    assert {m.agents for m in motion_models("displacement")} == {("pf",)}
    pose = {m.name: m.agents for m in motion_models("pose")}
    assert pose == {"constant-velocity": ("pose-baseline",), "smc": ("pose-smc",)}
    point, poses = (
        {a for m in models if m.kind != "pose" for a in m.agents},
        {a for m in models if m.kind == "pose" for a in m.agents},
    )
    assert all(agent_traits(AGENTS.factory(a)).position_rank == 1 for a in point)
    assert all(agent_traits(AGENTS.factory(a)).position_rank == 2 for a in poses)


def test_summaries_are_plain_text():
    for model in motion_models():
        assert model.summary and "``" not in model.summary and ":class:" not in model.summary
        assert len(model.summary) <= 101


def test_an_unknown_kind_is_named():
    with pytest.raises(
        ValueError, match=r"unknown motion model kind 'particle'; valid kinds are \['gaussian'"
    ):
        motion_models("particle")
