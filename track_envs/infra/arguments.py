"""Checks of constructor arguments, shared by every environment (and usable by agents).

Each check returns the value converted (``float`` or ``int``) or raises ``ValueError`` naming the
argument, what it must be and what it got. A value that is not a number at all (a string such as
``"1e-4"``, ``None``, a list, a bool) is named as such, before any numpy call could fail on it
with a ufunc ``TypeError``. Numbers are Python or numpy reals (``numbers.Real``) or 0-d numeric
arrays; bools are refused (``True`` is no noise level).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from numbers import Integral, Real
from typing import Any

import numpy as np
from numpy.typing import NDArray


def _got(value: Any) -> str:
    return f"{value!r} ({type(value).__name__})"


def _is_real(value: Any) -> bool:
    if isinstance(value, bool | np.bool_):
        return False
    if isinstance(value, Real):
        return True
    return isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"


def _checked_real(name: str, value: Any, kind: str, valid: str, ok: Callable[[float], bool]) -> float:
    """``value`` as a float; ``ValueError`` "``name`` must be a number``kind``" if it is not a real
    number, "``name`` must be ``valid``" if it fails ``ok``."""
    if not _is_real(value):
        raise ValueError(f"{name} must be a number{kind}, got {_got(value)}")
    out = float(value)
    if not ok(out):
        raise ValueError(f"{name} must be {valid}, got {value!r}")
    return out


def check_number(name: str, value: Any) -> float:
    """``value`` as a finite float, or ``ValueError`` naming ``name`` if it is not a finite number."""
    return _checked_real(name, value, "", "a finite number", math.isfinite)


def check_probability(name: str, value: Any) -> float:
    """``value`` as a float, or ``ValueError`` naming ``name`` if it is not a number in [0, 1]."""
    # the comparison also refuses NaN
    return _checked_real(
        name, value, " (a probability in [0, 1])", "a probability in [0, 1]", lambda x: 0.0 <= x <= 1.0
    )


def check_non_negative(name: str, value: Any) -> float:
    """``value`` as a float, or ``ValueError`` naming ``name`` if it is not a finite number >= 0."""
    return _checked_real(
        name, value, " (finite, >= 0)", "a finite number >= 0", lambda x: math.isfinite(x) and x >= 0.0
    )


def check_positive(name: str, value: Any) -> float:
    """``value`` as a float, or ``ValueError`` naming ``name`` if it is not a finite number > 0."""
    return _checked_real(
        name, value, " (finite, > 0)", "a finite number > 0", lambda x: math.isfinite(x) and x > 0.0
    )


def check_int(name: str, value: Any, low: int, high: int | None = None) -> int:
    """``value`` as an int, or ``ValueError`` naming ``name`` if it is not an integer in
    ``[low, high]`` (``high`` ``None``: no upper bound). Floats such as ``3.0`` are refused."""
    bounds = f">= {low}" if high is None else f"in [{low}, {high}]"
    if isinstance(value, bool | np.bool_) or not isinstance(value, Integral):
        raise ValueError(f"{name} must be an integer {bounds}, got {_got(value)}")
    out = int(value)
    if out < low or (high is not None and out > high):
        raise ValueError(f"{name} must be an integer {bounds}, got {value!r}")
    return out


def check_vector(name: str, value: Any, length: int) -> NDArray[np.float64]:
    """``value`` as a (length,) float64 array of finite numbers, or ``ValueError`` naming ``name``."""
    items = value.tolist() if isinstance(value, np.ndarray) else value
    try:
        ok = len(items) == length and all(_is_real(v) for v in items)
    except TypeError:
        ok = False
    arr = np.asarray(items, dtype=np.float64) if ok else np.zeros(0)
    if not ok or not np.isfinite(arr).all():
        raise ValueError(f"{name} must be {length} finite numbers, got {_got(value)}")
    return arr
