"""Training recipes: every learned family registers one beside its predictor."""

from __future__ import annotations

import pytest

from predictors import available_recipes
from predictors.training.recipes import RECIPES, TrainingRecipe, register_recipe, training_recipe

LEARNED = ["lstm", "mc-lstm", "nll-lstm", "displacement-lstm", "pose-lstm"]


@pytest.fixture
def scoped(monkeypatch):
    monkeypatch.setattr(RECIPES, "_factories", dict(RECIPES._factories))


def test_every_learned_family_registers_a_recipe_in_order():
    assert available_recipes() == LEARNED
    for kind in LEARNED:
        recipe = training_recipe(kind)
        assert recipe.kind == kind and recipe.help and callable(recipe.train)


def test_the_pose_recipe_adds_its_loss_flag():
    assert {o.name: o.default for o in training_recipe("pose-lstm").options} == {"loss": "nll"}
    assert training_recipe("lstm").options == ()


def test_unknown_kinds_and_mismatched_recipes_are_named(scoped):
    with pytest.raises(ValueError, match=r"unknown training recipe 'gru'; valid names are \['lstm'"):
        training_recipe("gru")
    with pytest.raises(ValueError, match="recipe of kind 'a' registered as 'b'"):
        register_recipe("b", TrainingRecipe("a", "help", train=lambda args: "x"))
    register_recipe("c", "predictors.belt_lstm.recipe")
    with pytest.raises(ValueError, match="unknown belt LSTM kind 'c'"):
        training_recipe("c")


def test_a_registered_recipe_joins_the_end_and_replaces_in_place(scoped):
    dummy = TrainingRecipe("dummy", "a dummy", train=lambda args: "x")
    register_recipe("dummy", dummy)
    assert available_recipes() == [*LEARNED, "dummy"] and training_recipe("dummy") is dummy
    register_recipe("lstm", TrainingRecipe("lstm", "other", train=lambda args: "y"))
    assert available_recipes() == [*LEARNED, "dummy"] and training_recipe("lstm").help == "other"
