"""The string registry: names, argument checks against the factory's signature, protocol gaps."""

from __future__ import annotations

from typing import Any, Protocol

import pytest

from track_envs.infra.registry import (
    Registry,
    UnknownArgumentError,
    keyword_arguments,
    missing_methods,
    named_arguments,
)


def tracker(*, speed: float = 1.0, gate: float = 3.0) -> dict[str, float]:
    return {"speed": speed, "gate": gate}


def forwarding(name: str = "x", **kwargs: Any) -> dict[str, Any]:
    return {"name": name, **kwargs}


def registry() -> Registry:
    r = Registry("tracker")
    r.register("plain", tracker)
    r.register("forwarding", forwarding)
    return r


def test_make_passes_known_keywords() -> None:
    assert registry().make("plain", gate=5.0) == {"speed": 1.0, "gate": 5.0}


def test_an_unknown_keyword_names_the_factory_and_its_arguments() -> None:
    with pytest.raises(
        UnknownArgumentError,
        match=r"tracker 'plain' has no argument 'gat'; its arguments are \['speed', 'gate'\]",
    ):
        registry().make("plain", gat=5.0)
    with pytest.raises(UnknownArgumentError, match=r"no arguments 'a', 'b'"):
        registry().make("plain", a=1, b=2)


def test_the_error_is_both_a_type_error_and_a_value_error() -> None:
    for kind in (TypeError, ValueError):
        with pytest.raises(kind):
            registry().make("plain", nope=1)


def test_a_factory_taking_any_keyword_is_not_checked() -> None:
    assert registry().make("forwarding", anything=1) == {"name": "x", "anything": 1}
    assert registry().arguments("forwarding") is None
    assert named_arguments(forwarding) == ["name"]
    assert keyword_arguments(tracker) == ["speed", "gate"]


def test_unknown_names_are_listed() -> None:
    with pytest.raises(
        ValueError, match=r"unknown tracker 'fancy'; valid names are \['forwarding', 'plain'\]"
    ):
        registry().make("fancy")


class Walker(Protocol):
    def step(self) -> None: ...

    def turn(self, angle: float) -> None: ...


class HalfWalker:
    def step(self) -> None:
        pass

    turn = 3


def test_missing_methods_of_a_protocol_are_named() -> None:
    assert missing_methods(object(), Walker) == ["step", "turn"]
    assert missing_methods(HalfWalker(), Walker) == ["turn"]
