"""A small string registry (predictors, agents): factories by name, errors that list the names."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


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

    def make(self, name: str, **kwargs: Any) -> Any:
        """Build the object registered as ``name`` with ``kwargs``.

        Raises:
            ValueError: for an unknown name, listing the valid names.
        """
        if name not in self._factories:
            raise ValueError(f"unknown {self.kind} {name!r}; valid names are {self.names()}")
        return self._factories[name](**kwargs)
