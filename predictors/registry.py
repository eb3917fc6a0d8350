"""The predictor registry: build a predictor by name, or resolve a name-or-object argument.

[`make_predictor`][predictors.make_predictor] builds the predictor registered under a name (an unknown name
raises a ``ValueError`` that lists the valid ones); [`resolve_predictor`][predictors.resolve_predictor] is
what a tracker calls with its ``predictor`` argument, a registered name or an object of the
[`Predictor`][predictors.Predictor] protocol.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from predictors.base import Predictor
from track_envs.infra.registry import (
    Registry,
    UnknownArgumentError,
    check_keywords,
    missing_methods,
    named_arguments,
)

PREDICTORS = Registry("predictor")

#: The env ids of the optical belt, where the belt LSTMs apply.
BELT_ENVS = ("BeltSorter-v0", "BeltReplay-v0")


#: The env ids each predictor was registered for (none: every point env).
_MEANT_FOR: dict[str, tuple[str, ...]] = {}


def register_predictor(
    name: str, factory: Callable[..., Predictor], *, envs: Sequence[str] | None = None
) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it).

    Args:
        name: The name [`make_predictor`][predictors.make_predictor] and ``make_agent(..., predictor=name)``
            take.
        factory: Builds the predictor; its keyword arguments are the predictor's.
        envs: The env ids the predictor is meant for (a learned model made for one geometry,
            e.g. the belt LSTMs: the belt envs); ``None`` (default): every point env.
    """
    PREDICTORS.register(name, factory)
    if envs is None:
        _MEANT_FOR.pop(name, None)
    else:
        _MEANT_FOR[name] = tuple(envs)


def available_predictors() -> list[str]:
    """Names accepted by [`make_predictor`][predictors.make_predictor]."""
    return PREDICTORS.names()


def predictor_applies_to(name: str, env_id: str) -> bool:
    """Whether predictor ``name`` is meant for ``env_id``.

    A predictor registered with ``envs`` (the env ids its model was made for: the belt LSTMs, the
    belt envs, whose geometry and motion their weights learnt) applies to those only; one
    registered without applies to every point env.
    """
    PREDICTORS.factory(name)  # an unknown name is an error listing the valid ones
    envs = _MEANT_FOR.get(name)
    return envs is None or env_id in envs


def make_predictor(name: str, **kwargs: Any) -> Predictor:
    """Build the predictor registered as ``name``.

    Raises:
        ValueError: for an unknown name, listing the valid ones.
        UnknownArgumentError: for a keyword the predictor does not take, listing those it takes.
    """
    predictor: Predictor = PREDICTORS.make(name, **kwargs)
    return predictor


def resolve_predictor(
    predictor: str | Predictor, /, *, owner: Callable[..., Any] | None = None, **kwargs: Any
) -> Predictor:
    """The predictor registered as ``predictor`` built with ``kwargs``, or the object ``predictor``
    itself after checking that it has the core methods.

    Args:
        predictor: A registered name ([`available_predictors`][predictors.available_predictors]) or a
            Predictor object.
        owner: The class (or factory) that takes ``predictor`` and passes ``kwargs`` on (a
            tracker); errors then name its own arguments too.
        **kwargs: Keyword arguments of the named predictor's factory; none with an object
            (configure an object before passing it).

    Raises:
        ValueError: for an unknown name (listing the registered ones) or an object lacking
            methods of the Predictor protocol (named).
        UnknownArgumentError: (a ``TypeError`` and a ``ValueError``) for a keyword the named
            predictor does not take (listing those it takes, and ``owner``'s), or any keyword with
            an object.
    """
    what = "predictor" if owner is None else owner.__name__
    own = [] if owner is None else named_arguments(owner)
    if isinstance(predictor, str):
        accepted = PREDICTORS.arguments(predictor)  # also refuses an unknown name
        if accepted is not None and owner is not None:
            note = (
                f", and it passes further keywords to predictor {predictor!r}, whose arguments are {accepted}"
            )
            check_keywords(what, [k for k in kwargs if k not in accepted], own, note)
        return make_predictor(predictor, **kwargs)
    if kwargs:
        names = ", ".join(map(repr, kwargs))
        its = f"; its arguments are {own}" if owner is not None else ""
        raise UnknownArgumentError(
            f"{what} has no argument {names}{its} (further keywords go to a predictor given by name; "
            "configure a predictor object before passing it)"
        )
    missing = missing_methods(predictor, Predictor)
    if missing:
        raise ValueError(
            f"predictor must be a registered name {available_predictors()} or implement the Predictor "
            f"protocol (predictors.base.Predictor); {type(predictor).__name__} lacks {missing}"
        )
    return predictor
