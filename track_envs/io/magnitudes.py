"""Coordinates no sensor produces: the readers' check for absurd magnitudes.

A file's coordinates (positions, box corners and sizes) are in its own units (metres, pixels,
millimetres), so no fixed range fits every file; what no sensor produces is a value absurdly far
from the rest of the data. With ``m`` the median of the file's finite position values (x and y
pooled) and ``S`` their spread, a cell is **extreme** when

* a position ``v``: ``|v - m| > MAX_SPREADS · S``;
* a size ``w`` (a box's width or height): ``|w| > MAX_SPREADS · S``;
* any coordinate: ``|v| > MAX_MAGNITUDE``.

``MAX_SPREADS`` is ``1e12``: beyond it, the data's own differences are below ``1e-12`` of that
value, fewer than 4 of float64's 16 significant digits, so no computation that mixes the value with
the data (the region's bounding box, distances, a Kalman filter's covariance) can resolve the data
any more. ``MAX_MAGNITUDE`` is ``1e150``: the square of a difference of two such values (a squared
distance) stays finite in float64 (at most ``1.8e308``).

The spread ``S`` is the median absolute deviation from ``m`` (robust: a few extreme values do not
move it); where more than half the values are equal (it is 0), the mean absolute deviation
``mean |v - m|`` instead; where every value equals ``m`` (both are 0) there is no relative bound
(only ``MAX_MAGNITUDE``: a file of one position repeated, with boxes of any size, is data). ``m``
and ``S`` are computed on at most [`SAMPLE`][track_envs.io.magnitudes.SAMPLE] values taken at a fixed stride
(so a 10^6-row file costs two medians of 65,536 values); the comparison is made on every cell, vectorised.
Infinities and NaN are not this module's business (the readers name them as non-finite first);
they are ignored here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_MAGNITUDE", "MAX_SPREADS", "SAMPLE", "Reference", "extreme", "message", "reference"]

#: A position farther than this many spreads from the median is extreme.
MAX_SPREADS = 1e12
#: No coordinate's magnitude may exceed this (squared differences stay finite in float64).
MAX_MAGNITUDE = 1e150
#: Most values the median and the spread are computed on.
SAMPLE = 1 << 16


class Reference:
    """The median ``m`` and spread ``S`` of a file's positions (module docstring)."""

    def __init__(self, median: float, spread: float) -> None:
        self.median = float(median)
        self.spread = float(spread)

    def describe(self) -> str:
        """``median M, spread S`` for messages."""
        return f"the file's positions have median {self.median:.6g} and spread {self.spread:.6g}"


def reference(positions: NDArray[np.float64]) -> Reference:
    """The [`Reference`][track_envs.io.magnitudes.Reference] of ``positions`` (any shape; NaN and infinities
    ignored)."""
    flat = np.asarray(positions, dtype=np.float64).reshape(-1)
    if len(flat) > 4 * SAMPLE:
        flat = flat[:: (len(flat) // SAMPLE) | 1]  # odd: x and y alike where they are interleaved
    flat = flat[np.isfinite(flat) & (np.abs(flat) <= MAX_MAGNITUDE)]
    if not len(flat):
        return Reference(0.0, 0.0)
    m = float(np.median(flat))
    deviation = np.abs(flat - m)
    spread = float(np.median(deviation))
    if spread == 0.0:
        spread = float(deviation.mean())
    return Reference(m, spread)


def extreme(values: NDArray[np.float64], ref: Reference, *, size: bool = False) -> NDArray[np.bool_]:
    """Mask of the extreme cells of ``values`` (positions, or sizes with ``size``) against ``ref``
    (module docstring); NaN and infinities are not extreme.

    The bounds ``m ± MAX_SPREADS·S`` (``±MAX_SPREADS·S`` for sizes), clipped to
    ``±MAX_MAGNITUDE``, are compared with the largest and the smallest value first (two
    NaN-ignoring reductions); only where one is out of bounds is the mask built."""
    limit = MAX_SPREADS * ref.spread if ref.spread > 0 else np.inf  # no spread: no relative bound
    centre = 0.0 if size else ref.median
    high = min(centre + limit, MAX_MAGNITUDE)
    low = max(centre - limit, -MAX_MAGNITUDE)
    values = np.asarray(values, dtype=np.float64)
    if not values.size or (
        np.fmax.reduce(values, axis=None) <= high and np.fmin.reduce(values, axis=None) >= low
    ):
        return np.zeros(values.shape, dtype=bool)  # the usual case: two reductions, no mask
    out = (values > high) | (values < low)
    return out & np.isfinite(values)


def message(value: float, ref: Reference, *, size: bool = False) -> str:
    """Why ``value`` is extreme, for a reader's error (after ``row R, column index C holds V``)."""
    if abs(value) > MAX_MAGNITUDE:
        return f"; no sensor gives a coordinate beyond {MAX_MAGNITUDE:g} in magnitude"
    what = "a size" if size else "a position"
    return (
        f", {what} beyond {MAX_SPREADS:g} times the data's spread ({ref.describe()}), which no sensor "
        "produces; correct or remove the row"
    )
