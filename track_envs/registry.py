"""A small string registry (predictors, agents): factories by name, errors that list the names.

:meth:`Registry.make` checks the keyword arguments against the factory's signature before calling
it, so that a misspelt or foreign argument is named with the arguments the factory does take
(instead of a ``TypeError`` from deep inside the object it builds). A factory that takes
``**kwargs`` checks what it forwards itself (see :func:`check_keywords`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable, Mapping
from typing import Any


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
    """Raise :class:`UnknownArgumentError` naming the names of ``given`` not in ``accepted``.

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
        """Raise :class:`UnknownArgumentError` if ``name``'s factory does not take every key of
        ``kwargs`` (nothing is checked for a factory that takes ``**kwargs``)."""
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
