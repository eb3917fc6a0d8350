"""Training recipes: how ``track train KIND`` trains each learned model kind, registered by kind.

A :class:`TrainingRecipe` declares one model kind's subcommand: its one-line help, the arguments
it adds to the shared data and training arguments, and ``train(args)``, which trains the model
on the data the arguments name, writes ``args.out`` (``.safetensors`` + ``.json``, see
:mod:`predictors.training.model_file`), prints one summary line and returns the sidecar's path.
Each learned family registers its recipes beside its predictor registration
(:mod:`predictors`), so ``track train`` (:mod:`track_apps.cli.train`) lists whatever is registered
and a new learned family edits no command-line code::

    register_recipe("my-lstm", TrainingRecipe("my-lstm", "my model", train=train_my_lstm))

A family whose modules import torch registers the *name of the module* instead; its
``recipe(kind)`` builds the recipe on first use (:func:`training_recipe`), so importing
:mod:`predictors` stays free of torch.

A recipe may run a post-training step that lives outside :mod:`predictors` (the ``lstm``
covariance line search runs a tracker, :mod:`track_apps.lstm_line_search`): that module registers it
with :func:`register_tuner`, and the recipe asks :func:`tuner_of` for it.
"""

from __future__ import annotations

import argparse
import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from track_envs.infra.registry import Registry


def _no_arguments(parser: argparse.ArgumentParser) -> None:
    """A recipe without arguments of its own."""


@dataclass(frozen=True)
class TrainingRecipe:
    """How ``track train KIND`` trains one model kind.

    Attributes:
        kind: The model kind, the subcommand's name (``"nll-lstm"``).
        help: One line: the subcommand's help in ``track train --help`` and its description.
        train: ``train(args) -> path``: train on the data ``args`` names (the shared data and
            training arguments of ``track train`` and the recipe's own), write the model file
            ``args.out``, print one summary line and return the sidecar's path. ``args.model`` is
            the kind, ``args.command`` the command line (the sidecar records it). Raises
            ``ValueError`` for bad input (``track train`` prints it as one line).
        add_arguments: Adds the recipe's own arguments to its subcommand's parser.
    """

    kind: str
    help: str
    train: Callable[[argparse.Namespace], str | os.PathLike[str]]
    add_arguments: Callable[[argparse.ArgumentParser], None] = _no_arguments


class _OrderedRegistry(Registry):
    """A registry that lists its names in registration order (the order ``track train`` shows)."""

    def names(self) -> list[str]:
        return list(self._factories)


#: Recipe loaders by kind: each returns the kind's :class:`TrainingRecipe`.
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


#: ``tune(model_path, args) -> dict``: a post-training step of a model kind; it may rewrite the
#: model file at ``model_path`` (the sidecar) and returns the entry ``training.tuning`` records.
Tuner = Callable[[Path, argparse.Namespace], dict[str, Any]]

#: Post-training steps by model kind (registered by the module that holds the step).
TUNERS = Registry("post-training step")


def register_tuner(kind: str, tune: Tuner) -> None:
    """Register ``tune`` as the post-training step of ``kind`` (replacing any)."""
    TUNERS.register(kind, tune)


def tuner_of(kind: str) -> Tuner | None:
    """The post-training step registered for ``kind``, ``None`` if there is none."""
    return TUNERS.factory(kind) if kind in TUNERS.names() else None
