"""A small string registry (predictors, agents): factories by name, errors that list the names.

[`Registry.make`][track_envs.infra.registry.Registry.make] checks the keyword arguments against the factory's
signature before calling it, so that a misspelt or foreign argument is named with the arguments the factory
does take (instead of a ``TypeError`` from deep inside the object it builds). A factory that takes
``**kwargs`` checks what it forwards itself (see
[`check_keywords`][track_envs.infra.registry.check_keywords]).

Keyword sets declared once: a constructor that forwards the keywords of settings declared
elsewhere (a frozen dataclass's fields, or another constructor's keywords) takes them as
``**options`` under [`takes_keywords_of`][track_envs.infra.registry.takes_keywords_of], which gives it the
signature it accepts (so `inspect.signature`, ``help()``,
[`named_arguments`][track_envs.infra.registry.named_arguments] and the bench see every keyword) and refuses
any other keyword by name; [`split_keywords`][track_envs.infra.registry.split_keywords] hands each source its
share.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeVar


class UnknownArgumentError(TypeError, ValueError):
    """A keyword argument that a factory does not take.

    Both a ``TypeError`` (what Python raises for an unexpected keyword) and a ``ValueError``
    (what the project raises for bad constructor arguments), so either ``except`` catches it.
    """


def named_arguments(factory: Callable[..., Any]) -> list[str]:
    """The parameters of ``factory`` that can be passed by keyword, by name (``**kwargs`` left
    out; empty when the signature cannot be inspected)."""
    try:
        parameters = inspect.signature(factory).parameters.values()
    except (TypeError, ValueError):
        return []
    keyword = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [p.name for p in parameters if p.kind in keyword]


def keyword_arguments(factory: Callable[..., Any]) -> list[str] | None:
    """The names ``factory`` accepts as keywords, or ``None`` when it takes any (``**kwargs``)
    or has no inspectable signature."""
    try:
        parameters = inspect.signature(factory).parameters.values()
    except (TypeError, ValueError):
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    return named_arguments(factory)


def check_keywords(what: str, given: Iterable[str], accepted: list[str], note: str = "") -> None:
    """Raise [`UnknownArgumentError`][track_envs.infra.registry.UnknownArgumentError] naming the names of
    ``given`` not in ``accepted``.

    Args:
        what: The object the arguments are for, e.g. ``"agent 'gnn'"``.
        given: Keyword names passed.
        accepted: Keyword names ``what`` takes.
        note: Appended to the message (e.g. where further keywords go).
    """
    unknown = [k for k in given if k not in accepted]
    if unknown:
        names = ", ".join(map(repr, unknown))
        plural = "arguments" if len(unknown) > 1 else "argument"
        raise UnknownArgumentError(f"{what} has no {plural} {names}; its arguments are {accepted}{note}")


def missing_methods(obj: Any, protocol: type) -> list[str]:
    """The public methods of ``protocol`` (a ``typing.Protocol`` class) that ``obj`` lacks or
    has as something not callable."""
    methods = [n for n, v in vars(protocol).items() if not n.startswith("_") and callable(v)]
    return [n for n in methods if not callable(getattr(obj, n, None))]


class Registry:
    """Factories registered under names.

    Args:
        kind: What the registry holds ("predictor", "agent"), for error messages.
    """

    def __init__(self, kind: str):
        self.kind = kind
        self._factories: dict[str, Callable[..., Any]] = {}

    def register(self, name: str, factory: Callable[..., Any]) -> None:
        """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
        self._factories[name] = factory

    def names(self) -> list[str]:
        """The registered names, sorted."""
        return sorted(self._factories)

    def factory(self, name: str) -> Callable[..., Any]:
        """The factory registered as ``name`` (``ValueError`` listing the names if unknown)."""
        if name not in self._factories:
            raise ValueError(f"unknown {self.kind} {name!r}; valid names are {self.names()}")
        return self._factories[name]

    def arguments(self, name: str) -> list[str] | None:
        """The keyword arguments of ``name``'s factory (``None``: it takes any, ``**kwargs``)."""
        return keyword_arguments(self.factory(name))

    def check_arguments(self, name: str, kwargs: Mapping[str, Any], note: str = "") -> None:
        """Raise [`UnknownArgumentError`][track_envs.infra.registry.UnknownArgumentError] if ``name``'s
        factory does not take every key of ``kwargs`` (nothing is checked for a factory that takes
        ``**kwargs``)."""
        accepted = self.arguments(name)
        if accepted is not None:
            check_keywords(f"{self.kind} {name!r}", kwargs, accepted, note)

    def make(self, name: str, **kwargs: Any) -> Any:
        """Build the object registered as ``name`` with ``kwargs``.

        Raises:
            ValueError: for an unknown name, listing the valid names.
            UnknownArgumentError: (a ``TypeError`` and a ``ValueError``) for a keyword the
                factory does not take, listing those it takes.
        """
        self.check_arguments(name, kwargs)
        return self.factory(name)(**kwargs)


F = TypeVar("F", bound=Callable[..., Any])

_KEYWORD = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)


def keyword_parameters(source: Callable[..., Any]) -> list[inspect.Parameter]:
    """The keywords ``source`` takes, as keyword-only parameters with their defaults and types:
    a dataclass's fields, or a constructor's (function's) keyword parameters."""
    if isinstance(source, type) and dataclasses.is_dataclass(source):
        empty = inspect.Parameter.empty
        return [
            inspect.Parameter(
                f.name,
                inspect.Parameter.KEYWORD_ONLY,
                default=empty if f.default is dataclasses.MISSING else f.default,
                annotation=f.type,
            )
            for f in dataclasses.fields(source)
            if f.init
        ]
    parameters = inspect.signature(source).parameters.values()
    return [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in parameters if p.kind in _KEYWORD]


def split_keywords(
    source: Callable[..., Any], options: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(taken, rest)``: the items of ``options`` that ``source`` takes (see
    [`keyword_parameters`][track_envs.infra.registry.keyword_parameters]) and the others."""
    names = {p.name for p in keyword_parameters(source)}
    taken = {k: v for k, v in options.items() if k in names}
    return taken, {k: v for k, v in options.items() if k not in names}


def takes_keywords_of(*sources: Callable[..., Any], exclude: Iterable[str] = ()) -> Callable[[F], F]:
    """Declare that a function (a constructor) taking ``**options`` takes the keywords of ``sources``.

    The decorated function's signature becomes its own parameters (less ``**options``) followed by
    the keywords of every source ([`keyword_parameters`][track_envs.infra.registry.keyword_parameters]) except
    those named in ``exclude``; a call with any other keyword raises
    [`UnknownArgumentError`][track_envs.infra.registry.UnknownArgumentError] naming it and listing the
    accepted keywords.

    Args:
        sources: Dataclasses or callables whose keywords the function forwards.
        exclude: Keywords of the sources that the function sets itself (not accepted).
    """
    skip = set(exclude)

    def decorate(function: F) -> F:
        own = inspect.signature(function)
        kept = [p for p in own.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        added = [p for source in sources for p in keyword_parameters(source) if p.name not in skip]
        signature = own.replace(parameters=[*kept, *added])  # raises on a name taken twice
        accepted = [p.name for p in signature.parameters.values() if p.kind in _KEYWORD and p.name != "self"]
        what = function.__qualname__.removesuffix(".__init__")

        @functools.wraps(function)
        def checked(*args: Any, **kwargs: Any) -> Any:
            check_keywords(what, kwargs, accepted)
            return function(*args, **kwargs)

        checked.__signature__ = signature  # type: ignore[attr-defined]
        return checked  # type: ignore[return-value]

    return decorate
