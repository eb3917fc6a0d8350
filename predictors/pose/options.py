"""Keyword settings declared once and taken by every constructor that forwards them.

A pose tracker is built from the keywords of several settings: the loop's
(:class:`agents.pose.baseline.PoseTrackingOptions`), the motion's
(:class:`predictors.pose_lstm.motion.SmcSettings`, or
:class:`~predictors.pose.constant_velocity.ConstantVelocityPose`'s ``smoothing``). Each set is
declared once — a frozen dataclass (its fields with their types and defaults, its docstring's
``Attributes``, its checks in ``__post_init__``) or a constructor's keyword parameters — and a
constructor that forwards them takes them as ``**options`` under :func:`takes_keywords_of`, which

* gives it the signature it accepts (its own parameters, then every keyword of each source with
  its default and type), so :func:`inspect.signature`, ``help()``, the agent registry
  (:func:`track_envs.registry.named_arguments`) and the bench see every keyword; and
* refuses a keyword that neither it nor any source takes, with a
  :class:`~track_envs.registry.UnknownArgumentError` that names it and lists the valid ones.

:func:`split_keywords` then hands each source the keywords it takes.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeVar

from track_envs.registry import check_keywords

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
    :func:`keyword_parameters`) and the others."""
    names = {p.name for p in keyword_parameters(source)}
    taken = {k: v for k, v in options.items() if k in names}
    return taken, {k: v for k, v in options.items() if k not in names}


def takes_keywords_of(*sources: Callable[..., Any], exclude: Iterable[str] = ()) -> Callable[[F], F]:
    """Declare that a function (a constructor) taking ``**options`` takes the keywords of ``sources``.

    The decorated function's signature becomes its own parameters (less ``**options``) followed by
    the keywords of every source (:func:`keyword_parameters`) except those named in ``exclude``;
    a call with any other keyword raises :class:`~track_envs.registry.UnknownArgumentError`
    naming it and listing the accepted keywords.

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
