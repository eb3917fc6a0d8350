"""Shared infrastructure of every layer: the compiled-kernel decorator, registries, argument checks
and the assignment solvers. Imports nothing else of [`track_envs`][track_envs]."""

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

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
