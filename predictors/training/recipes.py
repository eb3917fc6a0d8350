"""Training recipes: how ``track train KIND`` trains each learned model kind, registered by kind.

A [`TrainingRecipe`][predictors.TrainingRecipe] declares one model kind's subcommand: its one-line help, the
options it adds to the shared data and training settings ([`RecipeOption`][predictors.training.RecipeOption]),
and ``train(settings)``, which trains the model on the data the settings name
([`TrainingSettings`][predictors.training.TrainingSettings]), writes ``settings.out``
(``.safetensors`` + ``.json``, see [`predictors.training.model_file`][predictors.training.model_file]), prints
one summary line and returns the sidecar's path.
Each learned family registers its recipes beside its predictor registration
([`predictors`][predictors]), so ``track train`` ([`track_apps.cli.train`][track_apps.cli.train]) lists
whatever is registered and a new learned family edits no command-line code::

    register_recipe("my-lstm", TrainingRecipe("my-lstm", "my model", train=train_my_lstm))

A family whose modules import torch registers the *name of the module* instead; its
``recipe(kind)`` builds the recipe on first use ([`training_recipe`][predictors.training.training_recipe]), so
importing [`predictors`][predictors] stays free of torch.

A step after training that runs a tracker (the ``lstm`` covariance line search) is no part of a
recipe: the application that trains runs it on the written model file (``track train lstm``).
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass

from predictors.training.settings import RecipeOption, TrainingSettings
from track_envs.infra.registry import Registry


@dataclass(frozen=True)
class TrainingRecipe:
    """How ``track train KIND`` trains one model kind.

    Attributes:
        kind: The model kind, the subcommand's name (``"nll-lstm"``).
        help: One line: the subcommand's help in ``track train --help`` and its description.
        train: ``train(settings) -> path``: train on the data ``settings`` names (the shared
            data and training settings and the recipe's own ``options``), write the model file
            ``settings.out``, print one summary line and return the sidecar's path.
            ``settings.kind`` is the kind, ``settings.command`` the command (the sidecar records
            it). Raises ``ValueError`` for bad input (``track train`` prints it as one line).
        options: The recipe's own settings (``track train KIND --NAME``), read from
            ``settings.options``.
    """

    kind: str
    help: str
    train: Callable[[TrainingSettings], str | os.PathLike[str]]
    options: tuple[RecipeOption, ...] = ()


class _OrderedRegistry(Registry):
    """A registry that lists its names in registration order (the order ``track train`` shows)."""

    def names(self) -> list[str]:
        return list(self._factories)


#: Recipe loaders by kind: each returns the kind's [`TrainingRecipe`][predictors.TrainingRecipe].
RECIPES = _OrderedRegistry("training recipe")


def register_recipe(kind: str, recipe: TrainingRecipe | str) -> None:
    """Register how to train ``kind`` (re-registering a kind replaces it, in its place).

    Args:
        kind: The model kind (``track train KIND``).
        recipe: The recipe, or the name of the module whose ``recipe(kind)`` returns it (imported
            on first use, for families whose training imports torch).

    Raises:
        ValueError: a recipe whose ``kind`` is not ``kind``.
    """
    if isinstance(recipe, TrainingRecipe):
        if recipe.kind != kind:
            raise ValueError(f"recipe of kind {recipe.kind!r} registered as {kind!r}")
        fixed = recipe
        RECIPES.register(kind, lambda: fixed)
    else:
        module = recipe
        RECIPES.register(kind, lambda: _load(module, kind))


def _load(module: str, kind: str) -> TrainingRecipe:
    recipe = importlib.import_module(module).recipe(kind)
    if not isinstance(recipe, TrainingRecipe) or recipe.kind != kind:
        raise ValueError(f"{module}.recipe({kind!r}) returned {recipe!r}, not the recipe of {kind!r}")
    return recipe


def available_recipes() -> list[str]:
    """The model kinds ``track train`` trains, in registration order."""
    return RECIPES.names()


def training_recipe(kind: str) -> TrainingRecipe:
    """The recipe of ``kind`` (``ValueError`` listing the registered kinds if unknown)."""
    recipe: TrainingRecipe = RECIPES.factory(kind)()
    return recipe
