"""Declared plug-in capabilities: one way for every kind of plug-in to say what it offers.

A plug-in (a predictor, an agent, a particle displacement model, a pose motion, a tuning policy)
has a *core* — the calls every plug-in of its kind has — and may offer optional
*capabilities*. Each kind lists its capabilities in an `Enum` and gives each member
a `typing.Protocol` naming what the capability adds to the core. A plug-in class declares
what it offers in its class attribute ``capabilities: frozenset[Enum member]`` (none when
absent), and a consumer asks in exactly one way,
[`Declarations.get`][track_envs.infra.declared.Declarations.get] (or
[`Declarations.has`][track_envs.infra.declared.Declarations.has]), which returns the plug-in typed as the
capability's protocol, or ``None``. Consumers never probe a method or attribute name (``getattr`` /
``hasattr``), a signature, or a runtime-checkable protocol (``isinstance``): a method that is present but not
declared is never called.

The declaration is read from the class (a wrapper object declares its own), so it can also be
asked of a class or a registered factory before anything is built
([`Declarations.declares`][track_envs.infra.declared.Declarations.declares],
[`declared_value`][track_envs.infra.declared.declared_value]). The first
[`Declarations.get`][track_envs.infra.declared.Declarations.get] of a declared capability on a class checks
that the object has every member of the protocol (methods callable), and raises a ``TypeError`` naming what is
missing; the check is made once per (class, capability).

Fixed facts about a plug-in class (not capabilities, e.g. an agent's traits) are declared the same
way, as one class attribute holding one value, read with
[`declared_value`][track_envs.infra.declared.declared_value].
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum
from typing import Any, Generic, TypeVar

E = TypeVar("E", bound=Enum)
V = TypeVar("V")

#: The class attribute that holds a plug-in class's declared capabilities.
ATTRIBUTE = "capabilities"


def declaring_class(plugin: object) -> type:
    """The class whose declaration applies to ``plugin``: ``plugin`` itself if it is a class,
    else its type (a registered factory that is not a class declares nothing)."""
    return plugin if isinstance(plugin, type) else type(plugin)


def declared_value(plugin: object, attribute: str, kind: type[V], default: V) -> V:
    """The value of class attribute ``attribute`` that ``plugin``'s class (or ``plugin``, a class)
    declares, ``default`` where it declares none.

    Raises:
        TypeError: if the declared value is not a ``kind``, naming the class and the value.
    """
    owner = declaring_class(plugin)
    value: object = getattr(owner, attribute, default)
    if not isinstance(value, kind):
        raise TypeError(
            f"{owner.__name__}.{attribute} must be a {kind.__module__}.{kind.__qualname__}, got {value!r}"
        )
    return value


class Declarations(Generic[E]):
    """The optional capabilities of one kind of plug-in (module docstring).

    Args:
        enum: The capabilities (an Enum); errors list its members' names.
        protocols: The protocol of every member: the members it adds to ``core`` are what a
            declaring class must have.
        core: The protocol of the core, whose own members (e.g. ``reset`` with extra keywords)
            are not checked again: their presence is the core's check, their keywords the
            declaration's promise. ``None``: every member of the protocols is checked.

    Raises:
        ValueError: if ``protocols`` does not give exactly one protocol per member of ``enum``.
    """

    def __init__(self, enum: type[E], protocols: Mapping[E, type], core: type | None = None) -> None:
        if set(protocols) != set(enum):
            missing = sorted(m.name for m in set(enum) - set(protocols))
            extra = sorted(map(repr, set(protocols) - set(enum)))
            raise ValueError(
                f"protocols of {enum.__qualname__} must cover exactly its members; "
                f"missing {missing}, extra {extra}"
            )
        self.enum = enum
        self.protocols: dict[E, type] = dict(protocols)
        self._core = frozenset(vars(core)) if core is not None else frozenset()
        self._checked: set[tuple[type, E]] = set()

    def declared(self, plugin: object) -> frozenset[E]:
        """The capabilities ``plugin``'s class (or ``plugin``, a class) declares (empty when none).

        Raises:
            TypeError: if the class's ``capabilities`` is not a set of members of the enum.
        """
        owner = declaring_class(plugin)
        declared: object = getattr(owner, ATTRIBUTE, frozenset())
        if not isinstance(declared, frozenset | set) or not all(isinstance(c, self.enum) for c in declared):
            raise TypeError(
                f"{owner.__name__}.{ATTRIBUTE} must be a frozenset of "
                f"{self.enum.__module__}.{self.enum.__qualname__} members {[c.name for c in self.enum]}, "
                f"got {declared!r}"
            )
        return frozenset(declared)

    def declares(self, plugin: object, which: E) -> bool:
        """Whether ``plugin``'s class (or ``plugin``, a class or factory) declares ``which``,
        without checking its members (nothing need be built to ask)."""
        return self._checked_member(which) in self.declared(plugin)

    def get(self, plugin: object, which: E) -> Any:
        """``plugin``, to be typed as the protocol of ``which``, when its class declares it; else
        ``None``.

        Raises:
            TypeError: if the class declares ``which`` but ``plugin`` lacks a member of its
                protocol (named), or ``which`` is not a member of the enum.
        """
        if self._checked_member(which) not in self.declared(plugin):
            return None
        key = (type(plugin), which)
        if key not in self._checked:
            protocol = self.protocols[which]
            missing = self.missing_members(plugin, protocol)
            if missing:
                raise TypeError(
                    f"{type(plugin).__name__} declares capability {which.name} but lacks {missing} "
                    f"(see {protocol.__module__}.{protocol.__qualname__})"
                )
            self._checked.add(key)
        return plugin

    def has(self, plugin: object, which: E) -> bool:
        """Whether ``plugin``'s class declares ``which`` (its members checked as
        [`get`][track_envs.infra.declared.Declarations.get] does)."""
        return self.get(plugin, which) is not None

    def missing_members(self, plugin: object, protocol: type) -> list[str]:
        """The members ``protocol`` adds to the core that ``plugin`` lacks: its methods (which
        must be callable), then its annotated attributes."""
        own = vars(protocol)
        methods = [n for n, v in own.items() if callable(v) and not n.startswith("_") and n not in self._core]
        missing = [n for n in methods if not callable(getattr(plugin, n, None))]
        return missing + [n for n in own.get("__annotations__", {}) if not hasattr(plugin, n)]

    def _checked_member(self, which: object) -> E:
        if not isinstance(which, self.enum):
            raise TypeError(f"capability must be one of {[c.name for c in self.enum]}, got {which!r}")
        return which
