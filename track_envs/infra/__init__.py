"""Shared infrastructure of every layer: the compiled-kernel decorator, registries, argument checks
and the assignment solvers. Imports nothing else of :mod:`track_envs`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.infra.arguments import (
        check_int,
        check_non_negative,
        check_number,
        check_positive,
        check_probability,
        check_vector,
    )
    from track_envs.infra.compiled import njit
    from track_envs.infra.declared import Declarations
    from track_envs.infra.registry import Registry, UnknownArgumentError, takes_keywords_of

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "check_int": "track_envs.infra.arguments",
    "check_non_negative": "track_envs.infra.arguments",
    "check_number": "track_envs.infra.arguments",
    "check_positive": "track_envs.infra.arguments",
    "check_probability": "track_envs.infra.arguments",
    "check_vector": "track_envs.infra.arguments",
    "njit": "track_envs.infra.compiled",
    "Declarations": "track_envs.infra.declared",
    "Registry": "track_envs.infra.registry",
    "UnknownArgumentError": "track_envs.infra.registry",
    "takes_keywords_of": "track_envs.infra.registry",
}

__all__ = [
    "Declarations",
    "Registry",
    "UnknownArgumentError",
    "check_int",
    "check_non_negative",
    "check_number",
    "check_positive",
    "check_probability",
    "check_vector",
    "njit",
    "takes_keywords_of",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
