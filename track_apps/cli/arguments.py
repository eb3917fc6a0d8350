"""The arguments every ``track`` subcommand shares: one NAME=VALUE grammar and the common flags.

**NAME=VALUE grammar** (``--env-kwargs``, ``--agent-kwargs``, ``--fixed``, ``--sweep``)::

    assignments := NAME=VALUE ( "," NAME=VALUE )*
    VALUE       := number | true | false | none | 'quoted string' | bare word | [VALUE, ...]

Items are separated by commas (no spaces needed; spaces around items are ignored); a comma
inside quotes or brackets does not separate. A value is read as

- an ``int`` (``3``, ``-1``) or a ``float`` (``1e-4``, ``0.5``, ``inf``, ``nan``),
- ``True`` / ``False`` (``true`` / ``false``, any case) or ``None`` (``none`` / ``null``),
- a string: quoted (``'a b'``, ``"3"``) or a bare word (``sphere``, ``kf-ca``, ``data/run.csv``),
- a tuple: ``[1, 2]`` or ``(1e-4, 'a')``, its items read by the same rules.

Anything else (``1e-4x``, ``'a``) is an error that names the value, never a silent string: so
``particle_kind=sphere,noise_std=1e-4`` is two keyword arguments, never the kind
``'sphere,noise_std=1e-4'``. A name must be a Python identifier and may appear once.

**Shared flags** (each defined once here, each meaning one thing in every subcommand):
``--env``, ``--env-kwargs``, ``--agent-kwargs``, ``--seed`` / ``--seeds``, ``--out`` (its help says
whether it is a file, a file stem or a directory), ``--no-progress``, ``--workers``, and the two
noises: ``--declared-noise-std`` (the measurement noise the tracker is *told*, its R) and
``--added-noise-std`` (noise *added* to the training data).
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Literal

#: A bare word read as a string value (a name such as ``sphere`` or ``kf-ca``, a path).
WORD = re.compile(r"[A-Za-z_/.~][\w./~+-]*")
BOOLS = {"true": True, "false": False}
NONES = {"none", "null"}
#: Bracket pairs of a tuple value.
BRACKETS = {"[": "]", "(": ")"}


def split_items(text: str, sep: str = ",") -> list[str]:
    """``text`` split at every ``sep`` outside quotes and brackets (items not stripped).

    Raises:
        ValueError: for an unbalanced quote or bracket.
    """
    items, depth, quote, start = [], [], "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in BRACKETS:
            depth.append(BRACKETS[ch])
        elif ch in ")]":
            if not depth or depth.pop() != ch:
                raise ValueError(f"{text!r} has an unbalanced {ch!r}")
        elif ch == sep and not depth:
            items.append(text[start:i])
            start = i + 1
    if quote:
        raise ValueError(f"{text!r} has unbalanced quotes")
    if depth:
        raise ValueError(f"{text!r} has an unclosed bracket (missing {depth[-1]!r})")
    items.append(text[start:])
    return items


def parse_value(text: str) -> Any:
    """One value of the NAME=VALUE grammar (see the module docstring).

    ``"3"`` → 3, ``"1e-4"`` → 0.0001, ``"True"`` → True, ``"none"`` → None, ``"'a b'"`` → ``"a b"``,
    ``"sphere"`` → ``"sphere"``, ``"[1, x]"`` → ``(1, "x")``.

    Raises:
        ValueError: for an empty value, unbalanced quotes or brackets, or text that is none of
            these (e.g. ``1e-4x``, which starts like a number but is not one).
    """
    text = text.strip()
    if not text:
        raise ValueError("empty value")
    low = text.lower()
    if low in BOOLS:
        return BOOLS[low]
    if low in NONES:
        return None
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        pass
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"":
        return text[1:-1]
    if text[0] in "'\"" or text[-1] in "'\"":
        raise ValueError(f"{text!r} has unbalanced quotes")
    if text[0] in BRACKETS:
        if text[-1] != BRACKETS[text[0]]:
            raise ValueError(f"{text!r} has an unclosed bracket (missing {BRACKETS[text[0]]!r})")
        inner = text[1:-1]
        items = split_items(inner) if inner.strip() else []
        if items and not items[-1].strip():  # a trailing comma: (1,)
            items.pop()
        return tuple(parse_value(item) for item in items)
    if WORD.fullmatch(text) and not text[0].isdigit():
        return text
    raise ValueError(f"{text!r} is not a number, true/false, none or a name (quote other strings: 'a b')")


def parse_assignment(flag: str, text: str) -> tuple[str, str]:
    """``"name=rest"`` → ``("name", "rest")``, checking that ``name`` is an identifier.

    Raises:
        argparse.ArgumentTypeError: without ``=``, with nothing after it, or with a name that is
            not an identifier.
    """
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not rest.strip():
        raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: use name=value")
    if not name.isidentifier():
        raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: {name!r} is not a keyword argument name")
    return name, rest


def parse_assignments(text: str, flag: str = "--env-kwargs") -> dict[str, Any]:
    """``"p_gate=0.99,max_misses=3"`` → ``{"p_gate": 0.99, "max_misses": 3}`` (the NAME=VALUE
    grammar of the module docstring; ``flag`` names the option in errors).

    Raises:
        argparse.ArgumentTypeError: naming ``flag``, the text and what is wrong with it.
    """
    try:
        items = split_items(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: {exc}") from None
    out: dict[str, Any] = {}
    for item in items:
        name, rest = parse_assignment(flag, item)
        if name in out:
            raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: {name} is given twice")
        try:
            out[name] = parse_value(rest)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: {name}: {exc}") from None
    return out


def kwargs_type(flag: str) -> Callable[[str], dict[str, Any]]:
    """An argparse ``type`` reading ``flag``'s value with
    [`parse_assignments`][track_apps.cli.arguments.parse_assignments]."""

    def parse(text: str) -> dict[str, Any]:
        return parse_assignments(text, flag)

    parse.__name__ = flag.lstrip("-").replace("-", "_")  # argparse names the type in its errors
    return parse


def parse_kwargs(text: str) -> tuple[tuple[str, Any], ...]:
    """``"p_gate=0.99,max_misses=3"`` → sorted ``(name, value)`` pairs (hashable: a cell's
    ``agent_kwargs``); the grammar of [`parse_assignments`][track_apps.cli.arguments.parse_assignments]."""
    return tuple(sorted(parse_assignments(text, "--agent-kwargs").items()))


def parse_sweep(text: str) -> tuple[str, tuple[Any, ...]]:
    """``"noise_std=0,1e-4,2e-4"`` → ``("noise_std", (0, 0.0001, 0.0002))``: one name, then its
    values (each as in [`parse_value`][track_apps.cli.arguments.parse_value], each at most once)."""
    name, rest = parse_assignment("--sweep", text)
    values = []
    try:
        parts = split_items(rest)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"bad --sweep {text!r}: {exc}") from None
    for i, part in enumerate(parts):
        try:
            values.append(parse_value(part))
        except ValueError as exc:
            msg = f"bad --sweep {text!r}: value {i + 1} of {name}: {exc}"
            raise argparse.ArgumentTypeError(msg) from None
    seen: list[Any] = []
    for v in values:
        if any(v == s and isinstance(v, bool) == isinstance(s, bool) for s in seen):
            raise argparse.ArgumentTypeError(f"bad --sweep {text!r}: {name}={v!r} is given twice")
        seen.append(v)
    return name, tuple(values)


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"5"`` → 0..4; ``"3:7"`` → 3..6; ``"0,4,9"`` → those seeds."""
    try:
        if "," in text:
            return tuple(int(s) for s in text.split(",") if s.strip())
        if ":" in text:
            lo, hi = text.split(":")
            return tuple(range(int(lo), int(hi)))
        return tuple(range(int(text)))
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad --seeds {text!r}: use N, A:B or a,b,c") from None


def parse_names(text: str) -> tuple[str, ...]:
    """``"a, b,,c"`` → ``("a", "b", "c")``: a comma list of names."""
    return tuple(n.strip() for n in text.split(",") if n.strip())


def names_type(kind: str, valid: Sequence[str]) -> Callable[[str], tuple[str, ...]]:
    """An argparse ``type`` for a comma list of ``kind`` names, each one of ``valid``."""

    def parse(text: str) -> tuple[str, ...]:
        names = parse_names(text)
        unknown = [n for n in names if n not in valid]
        if unknown:
            msg = f"unknown {kind} {', '.join(map(repr, unknown))}; valid names are {list(valid)}"
            raise argparse.ArgumentTypeError(msg)
        return names

    return parse


def parse_noise(text: str) -> float | tuple[float, float]:
    """An added noise std: ``"1e-4"`` → 0.0001, or ``"LOW:HIGH"`` → ``(LOW, HIGH)`` (a per-track
    std drawn uniformly from that range)."""
    lo, sep, hi = text.partition(":")
    try:
        return (float(lo), float(hi)) if sep else float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or LOW:HIGH, got {text!r}") from None


def parse_rates(text: str) -> tuple[float, ...]:
    """Comma-separated numbers: ``"0.001,0.002"`` → ``(0.001, 0.002)``."""
    try:
        rates = tuple(float(r) for r in text.split(",") if r.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated rates, got {text!r}") from None
    if not rates:
        raise argparse.ArgumentTypeError(f"expected comma-separated rates, got {text!r}")
    return rates


# ------------------------------------------------------------------------------------- shared flags


def add_env(parser: Any, *, help: str, **kwargs: Any) -> None:
    """``--env ID``: a registered env id (gym id), e.g. ``BeltSorter-v0``."""
    parser.add_argument("--env", metavar="ID", help=help, **kwargs)


def add_env_kwargs(parser: Any, *, help: str) -> None:
    """``--env-kwargs NAME=V,...``: keyword arguments for ``gym.make`` (a dict; default empty)."""
    parser.add_argument(
        "--env-kwargs",
        type=kwargs_type("--env-kwargs"),
        default={},
        metavar="NAME=V,...",
        help=f"{help} (NAME=VALUE grammar: see 'track --help')",
    )


def add_agent_kwargs(parser: Any, *, help: str, **kwargs: Any) -> None:
    """``--agent-kwargs NAME=V,...``: keyword arguments for ``make_agent`` (sorted pairs)."""
    parser.add_argument("--agent-kwargs", type=parse_kwargs, metavar="NAME=V,...", help=help, **kwargs)


def add_seed(parser: Any, *, help: str, default: int = 0) -> None:
    """``--seed N``: one integer seed (``help`` says what it seeds)."""
    parser.add_argument("--seed", type=int, default=default, help=f"{help} (default {default})")


def add_seeds(parser: Any, *, help: str, default: tuple[int, ...] | None = None) -> None:
    """``--seeds N|A:B|a,b,c``: seeds 0..N-1, A..B-1 or those listed
    ([`parse_seeds`][track_apps.cli.arguments.parse_seeds])."""
    parser.add_argument("--seeds", type=parse_seeds, default=default, metavar="N|A:B|a,b,c", help=help)


OutKind = Literal["file", "stem", "directory"]
_OUT_KIND = {
    "file": "a file",
    "stem": "a path without suffix (the command adds the suffixes)",
    "directory": "a directory (created if missing)",
}


def add_out(parser: Any, *, kind: OutKind, help: str, **kwargs: Any) -> None:
    """``--out``: where the command writes; its help says whether it is a file, a stem or a directory."""
    default = kwargs.get("default")
    text = f"{help}: {_OUT_KIND[kind]}"
    if default is not None:
        text += f" (default {default})"
    parser.add_argument("--out", help=text, **kwargs)


def add_no_progress(parser: Any) -> None:
    """``--no-progress``: hide the progress bars (tqdm ``disable=``)."""
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_workers(parser: Any, *, default: int | None, help: str) -> None:
    """``--workers N``: local worker processes (``help`` says what runs in them)."""
    shown = "CPU count" if default is None else str(default)
    parser.add_argument(
        "--workers", type=int, default=default, help=f"{help} (default {shown}; 1 = in-process)"
    )


def add_declared_noise(parser: Any) -> None:
    """``--declared-noise-std``: the measurement noise std the tracker is told (its R)."""
    parser.add_argument(
        "--declared-noise-std",
        dest="declared_noise_std",
        type=float,
        default=0.0,
        metavar="STD",
        help="measurement noise std per axis the tracker is told (its R), in the detections' units "
        "after --scale; nothing is added to the data (default 0)",
    )


def add_added_noise(parser: Any) -> None:
    """``--added-noise-std``: noise added to the (training) positions."""
    parser.add_argument(
        "--added-noise-std",
        dest="added_noise_std",
        type=parse_noise,
        default=0.0,
        metavar="STD|LOW:HIGH",
        help="Gaussian noise std added to the positions (sensor units), or LOW:HIGH for a per-track "
        "std drawn uniformly (default 0)",
    )


def example_block(epilog: str | None) -> list[str]:
    """The lines of the ``examples:`` (or ``example:``) blocks of a help epilog, each block from
    its header to the next blank line."""
    out: list[str] = []
    inside = False
    for line in (epilog or "").splitlines():
        if line.strip() in ("examples:", "example:"):
            inside = True
        elif not line.strip():
            inside = False
        elif inside:
            out.append(line)
    return out


def example_lines(epilog: str | None, prog: str) -> Iterator[str]:
    """The example commands of a help epilog that start with ``prog``: lines of its examples
    block ([`example_block`][track_apps.cli.arguments.example_block]), with ``\\``-continued lines joined."""
    lines = example_block(epilog)
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        if line.startswith(prog + " "):
            command = line
            while command.endswith("\\") and i + 1 < len(lines):
                i += 1
                command = command[:-1].rstrip() + " " + lines[i].strip()
            yield command
        i += 1
