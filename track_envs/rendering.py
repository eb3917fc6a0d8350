"""A tiny dependency-free numpy rasteriser for the environments' ``render()``.

:class:`Canvas` draws filled discs, rings, markers, line segments, filled convex polygons and
axis-aligned rectangles into a ``uint8`` (H, W, 3) image. Every drawing method is vectorised over
its ``n`` items; no display, matplotlib or pygame is needed. :class:`HumanWindow` shows such frames
in a pygame window for ``render_mode="human"`` (pygame is imported lazily).

Coordinate conventions:

* World coordinates have x to the right and y **up**. ``world_low`` maps to the left / bottom edge
  of the image, ``world_high`` to the right / top edge (a per-axis scale; pick ``width`` and
  ``height`` to keep the aspect ratio).
* Pixel coordinates are continuous ``(col, row)`` with row 0 at the top; pixel ``(i, j)`` covers
  ``[i, i + 1) x [j, j + 1)`` and its centre is ``(i + 0.5, j + 0.5)``.
* Items partly or wholly off the canvas are clipped silently; items with a NaN (or infinite)
  coordinate are skipped. Later items are painted over earlier ones.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Canvas", "HumanWindow", "identity_colors"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
ColorArray = NDArray[np.uint8]

# Golden-ratio conjugate used to step hues for identity colours.
_GOLDEN = 0.6180339887498949

# spans(item indices (m,), row-centre rows (m,)) -> (x_lo, x_hi), each (m,) or (m, s).
_SpanFn = Callable[[IntArray, FloatArray], tuple[FloatArray, FloatArray]]


def _as_points(points: ArrayLike) -> FloatArray:
    """Returns ``points`` as a float (n, 2) array (a single (2,) point becomes (1, 2))."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == 2:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"expected points of shape (n, 2), got {arr.shape}")
    return arr


def _as_colors(color: ArrayLike, n: int) -> ColorArray:
    """Broadcasts a (3,) or (n, 3) colour spec to a ``uint8`` (n, 3) array (values clipped to 0..255)."""
    arr = np.asarray(color)
    if arr.ndim == 1:
        if arr.shape[0] != 3:
            raise ValueError(f"expected an RGB colour of shape (3,), got {arr.shape}")
        arr = np.broadcast_to(arr, (n, 3))
    elif arr.shape != (n, 3):
        raise ValueError(f"expected colours of shape (3,) or ({n}, 3), got {arr.shape}")
    if arr.dtype == np.uint8:
        return np.ascontiguousarray(arr)
    return np.clip(np.rint(arr.astype(np.float64)), 0, 255).astype(np.uint8)


def _as_per_item(value: ArrayLike, n: int, name: str) -> FloatArray:
    """Broadcasts a scalar or (n,) array to a float (n,) array."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"expected {name} as a scalar or of shape ({n},), got {arr.shape}")
    return arr


def _sqrt_or_nan(values: FloatArray) -> FloatArray:
    """Square root where ``values >= 0`` and NaN (an empty span) elsewhere, without warnings."""
    return np.sqrt(np.where(values >= 0, values, np.nan))


def _expand(counts: IntArray) -> tuple[IntArray, IntArray]:
    """Run-length expansion: ``owner`` repeats ``i`` ``counts[i]`` times, ``step`` counts 0.. within.

    Example: ``counts = [2, 0, 3]`` gives ``owner = [0, 0, 2, 2, 2]`` and ``step = [0, 1, 0, 1, 2]``.
    """
    counts = np.asarray(counts, dtype=np.int64)
    owner = np.repeat(np.arange(counts.size, dtype=np.int64), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    return owner, np.arange(owner.size, dtype=np.int64) - first


class Canvas:
    """An RGB raster image with a world-to-pixel transform and vectorised drawing primitives.

    Args:
        width: Image width in pixels.
        height: Image height in pixels.
        world_low: World coordinates ``(x, y)`` of the bottom-left corner of the image.
        world_high: World coordinates ``(x, y)`` of the top-right corner of the image.
        background: RGB background colour.

    Example:
        >>> canvas = Canvas(200, 100, (0.0, 0.0), (2.0, 1.0))
        >>> canvas.discs([[1.0, 0.5]], 4, (255, 0, 0))
        >>> canvas.image.shape
        (100, 200, 3)
    """

    def __init__(
        self,
        width: int,
        height: int,
        world_low: tuple[float, float],
        world_high: tuple[float, float],
        background: ArrayLike = (255, 255, 255),
    ) -> None:
        if int(width) < 1 or int(height) < 1:
            raise ValueError(f"canvas size must be positive, got {width}x{height}")
        self.width = int(width)
        self.height = int(height)
        self.world_low = np.asarray(world_low, dtype=np.float64).reshape(2)
        self.world_high = np.asarray(world_high, dtype=np.float64).reshape(2)
        span = self.world_high - self.world_low
        if not np.all(np.isfinite(span)) or np.any(span <= 0):
            raise ValueError(f"world_high must exceed world_low, got {world_low} and {world_high}")
        self._scale = np.array([self.width, self.height], dtype=np.float64) / span
        self.background = _as_colors(background, 1)[0]
        self._image: ColorArray = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self.clear()

    # ------------------------------------------------------------------ image access

    @property
    def image(self) -> ColorArray:
        """The ``uint8`` (H, W, 3) image itself (not a copy; later drawing changes it)."""
        return self._image

    def to_array(self) -> ColorArray:
        """Returns a copy of the ``uint8`` (H, W, 3) image."""
        return self._image.copy()

    def clear(self) -> None:
        """Fills the whole image with the background colour."""
        self._image[...] = self.background

    # ------------------------------------------------------------------ transform

    def to_pixels(self, points: ArrayLike) -> FloatArray:
        """Maps world points to continuous pixel coordinates.

        Args:
            points: World points, shape (n, 2) (a single (2,) point is accepted).

        Returns:
            Float array (n, 2) of ``(col, row)``; row 0 is the top of the image (``world_high[1]``).
            NaN stays NaN.
        """
        pts = _as_points(points)
        out = np.empty_like(pts)
        with np.errstate(over="ignore", invalid="ignore"):  # huge values become inf and are skipped
            out[:, 0] = (pts[:, 0] - self.world_low[0]) * self._scale[0]
            out[:, 1] = (self.world_high[1] - pts[:, 1]) * self._scale[1]
        return out

    # ------------------------------------------------------------------ primitives

    def fill_rect(self, low: ArrayLike, high: ArrayLike, color: ArrayLike) -> None:
        """Fills an axis-aligned world rectangle (pixels whose centres lie inside it).

        Args:
            low: World corner ``(x_min, y_min)``.
            high: World corner ``(x_max, y_max)``.
            color: RGB colour, shape (3,).
        """
        corners = self.to_pixels(np.stack([np.asarray(low, float), np.asarray(high, float)]))
        if not np.all(np.isfinite(corners)):
            return
        lo = np.min(corners, axis=0)
        hi = np.max(corners, axis=0)
        limits = np.array([self.width, self.height], dtype=np.float64)
        lo_i = np.rint(np.clip(lo, 0, limits)).astype(np.int64)
        hi_i = np.rint(np.clip(hi, 0, limits)).astype(np.int64)
        if hi_i[0] > lo_i[0] and hi_i[1] > lo_i[1]:
            self._image[lo_i[1] : hi_i[1], lo_i[0] : hi_i[0]] = _as_colors(color, 1)[0]

    def discs(self, centers: ArrayLike, radius_px: ArrayLike, color: ArrayLike) -> None:
        """Draws filled discs (pixels whose centres lie within ``radius_px`` of a centre).

        Args:
            centers: World centres, shape (n, 2).
            radius_px: Radius in pixels, a scalar or shape (n,); values below 1 are raised to 1, so
                the pixel holding the centre is always filled.
            color: RGB colour, shape (3,) or (n, 3).
        """
        pix = self.to_pixels(centers)
        n = pix.shape[0]
        radius = np.maximum(_as_per_item(radius_px, n, "radius_px"), 1.0)
        cx, cy = pix[:, 0], pix[:, 1]
        ok = np.all(np.isfinite(pix), axis=1) & np.isfinite(radius)
        r2 = radius**2

        def spans(item: IntArray, yc: FloatArray) -> tuple[FloatArray, FloatArray]:
            half = _sqrt_or_nan(r2[item] - (yc - cy[item]) ** 2)
            return cx[item] - half, cx[item] + half

        self._fill_spans(cy - radius, cy + radius, ok, spans, _as_colors(color, n))

    def rings(
        self, centers: ArrayLike, radius_px: ArrayLike, color: ArrayLike, thickness_px: float = 1
    ) -> None:
        """Draws circle outlines (pixels whose centres are within ``thickness_px / 2`` of the circle).

        Args:
            centers: World centres, shape (n, 2).
            radius_px: Radius in pixels, a scalar or shape (n,); values below 1 are raised to 1.
            color: RGB colour, shape (3,) or (n, 3).
            thickness_px: Line thickness in pixels (at least 1).
        """
        pix = self.to_pixels(centers)
        n = pix.shape[0]
        radius = np.maximum(_as_per_item(radius_px, n, "radius_px"), 1.0)
        half = max(float(thickness_px), 1.0) / 2.0
        cx, cy = pix[:, 0], pix[:, 1]
        ok = np.all(np.isfinite(pix), axis=1) & np.isfinite(radius)
        outer2 = (radius + half) ** 2
        inner2 = np.maximum(radius - half, 0.0) ** 2

        def spans(item: IntArray, yc: FloatArray) -> tuple[FloatArray, FloatArray]:
            dy2 = (yc - cy[item]) ** 2
            w_out = _sqrt_or_nan(outer2[item] - dy2)
            # Rows that miss the hole get two touching spans meeting at the centre.
            w_in = np.sqrt(np.maximum(inner2[item] - dy2, 0.0))
            x = cx[item]
            lo = np.stack([x - w_out, x + w_in], axis=1)
            hi = np.stack([x - w_in, x + w_out], axis=1)
            return lo, hi

        outer = radius + half
        self._fill_spans(cy - outer, cy + outer, ok, spans, _as_colors(color, n))

    def crosses(
        self,
        points: ArrayLike,
        size_px: float,
        color: ArrayLike,
        style: Literal["x", "+"] = "x",
        thickness_px: int = 1,
    ) -> None:
        """Draws small ``x`` (diagonal) or ``+`` (axis-aligned) markers.

        Args:
            points: World marker centres, shape (n, 2).
            size_px: Full width of a marker in pixels (at least 1).
            color: RGB colour, shape (3,) or (n, 3).
            style: ``"x"`` for a diagonal cross, ``"+"`` for an upright one.
            thickness_px: Line thickness in pixels.
        """
        pix = self.to_pixels(points)
        colors = _as_colors(color, pix.shape[0])
        h = max(float(size_px), 1.0) / 2.0
        if style == "x":
            arms = (np.array([-h, -h]), np.array([h, h]), np.array([-h, h]), np.array([h, -h]))
        elif style == "+":
            arms = (np.array([-h, 0.0]), np.array([h, 0.0]), np.array([0.0, -h]), np.array([0.0, h]))
        else:
            raise ValueError(f"style must be 'x' or '+', got {style!r}")
        # Interleave the two arms per marker so that paint order stays marker by marker.
        p0 = np.stack([pix + arms[0], pix + arms[2]], axis=1).reshape(-1, 2)
        p1 = np.stack([pix + arms[1], pix + arms[3]], axis=1).reshape(-1, 2)
        self._segments_px(p0, p1, np.repeat(colors, 2, axis=0), thickness_px)

    def segments(self, p0: ArrayLike, p1: ArrayLike, color: ArrayLike, thickness_px: int = 1) -> None:
        """Draws line segments from ``p0[i]`` to ``p1[i]``.

        Segments are clipped to the canvas first. One-pixel lines are sampled less than a pixel
        apart, so the drawn pixels are 8-connected; thicker lines are filled as rectangles of width
        ``thickness_px`` extended by half the width past each end (square caps).

        Args:
            p0: World start points, shape (n, 2).
            p1: World end points, shape (n, 2).
            color: RGB colour, shape (3,) or (n, 3).
            thickness_px: Line thickness in pixels (at least 1).
        """
        a = self.to_pixels(p0)
        b = self.to_pixels(p1)
        if a.shape != b.shape:
            raise ValueError(f"p0 and p1 must have the same shape, got {a.shape} and {b.shape}")
        self._segments_px(a, b, _as_colors(color, a.shape[0]), thickness_px)

    def polygons(self, vertices: ArrayLike, color: ArrayLike) -> None:
        """Draws filled convex polygons (either winding).

        A pixel is filled when its centre passes every edge's half-plane test (evaluated as one
        span per pixel row). The pixel holding each polygon's vertex centroid is always filled, so
        sub-pixel polygons stay visible.

        Args:
            vertices: World vertices, shape (n, k, 2) with ``k >= 3`` (a single (k, 2) polygon is
                accepted).
            color: RGB colour, shape (3,) or (n, 3).
        """
        verts = np.asarray(vertices, dtype=np.float64)
        if verts.ndim == 2:
            verts = verts[None]
        if verts.ndim != 3 or verts.shape[2] != 2 or verts.shape[1] < 3:
            raise ValueError(f"expected vertices of shape (n, k>=3, 2), got {verts.shape}")
        n, k = verts.shape[0], verts.shape[1]
        pix = self.to_pixels(verts.reshape(-1, 2)).reshape(n, k, 2)
        self._polygons_px(pix, _as_colors(color, n))

    # ------------------------------------------------------------------ internals

    def _polygons_px(self, pix: FloatArray, colors: ColorArray) -> None:
        """Fills convex polygons given in pixel coordinates, shape (n, k, 2) (see :meth:`polygons`)."""
        k = pix.shape[1]
        ok = np.all(np.isfinite(pix), axis=(1, 2))
        vx = np.where(ok[:, None], pix[..., 0], 0.0)
        vy = np.where(ok[:, None], pix[..., 1], 0.0)
        ex = np.roll(vx, -1, axis=1) - vx
        ey = np.roll(vy, -1, axis=1) - vy
        # Orient every polygon counter-clockwise in (col, row) space so "inside" is one sign.
        with np.errstate(over="ignore", invalid="ignore"):
            area2 = np.sum(vx * np.roll(vy, -1, axis=1) - np.roll(vx, -1, axis=1) * vy, axis=1)
        sign = np.where(area2 < 0, -1.0, 1.0)
        centroid = np.stack([vx.mean(axis=1), vy.mean(axis=1)], axis=1)

        def spans(item: IntArray, yc: FloatArray) -> tuple[FloatArray, FloatArray]:
            # Inside edge j: s * (ex * (y - vy) - ey * (x - vx)) >= 0, i.e. a * x + b >= 0 with
            # a = -s * ey and b = s * (ex * (y - vy) + ey * vx): a lower or upper bound on x.
            lo = np.full(item.shape, -np.inf)
            hi = np.full(item.shape, np.inf)
            s = sign[item]
            for j in range(k):  # loop over the (few) edges, vectorised over all polygon rows
                a = -s * ey[item, j]
                b = s * (ex[item, j] * (yc - vy[item, j]) + ey[item, j] * vx[item, j])
                flat = np.abs(a) <= 1e-12
                with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                    bound = -b / np.where(flat, 1.0, a)
                lo = np.where(~flat & (a > 0), np.maximum(lo, bound), lo)
                hi = np.where(~flat & (a < 0), np.minimum(hi, bound), hi)
                hi = np.where(flat & (b < -1e-9), -np.inf, hi)
            return lo, hi

        self._fill_spans(vy.min(axis=1), vy.max(axis=1), ok, spans, colors, always=centroid)

    def _fill_spans(
        self,
        y_lo: FloatArray,
        y_hi: FloatArray,
        ok: BoolArray,
        spans: _SpanFn,
        colors: ColorArray,
        always: FloatArray | None = None,
    ) -> None:
        """Fills shapes described by horizontal pixel spans, painting items in order.

        For every item and every pixel row whose centre lies in ``[y_lo, y_hi]`` (clipped to the
        image), ``spans`` gives one or more column intervals; pixels whose centres fall in an
        interval are coloured. All items are handled in one vectorised pass, with cost
        proportional to rows plus coloured pixels.

        Args:
            y_lo: Per-item top of the shape in pixel coordinates, shape (n,).
            y_hi: Per-item bottom of the shape, shape (n,).
            ok: Items to draw, shape (n,) (others, e.g. NaN ones, are skipped).
            spans: ``spans(item, yc)`` with ``item`` (m,) item indices and ``yc`` (m,) row-centre
                coordinates; returns ``(x_lo, x_hi)`` of shape (m,) or (m, s) (``s`` spans per row,
                NaN or ``x_lo > x_hi`` for an empty span).
            colors: ``uint8`` colours, shape (n, 3).
            always: Optional per-item pixel point, shape (n, 2), whose pixel is coloured regardless.
        """
        height, width = self.height, self.width
        okf = ok & np.isfinite(y_lo) & np.isfinite(y_hi)
        r0 = np.ceil(np.clip(np.where(okf, y_lo, 0.0) - 0.5, -1.0, height + 1.0)).astype(np.int64)
        r1 = np.floor(np.clip(np.where(okf, y_hi, -1.0) - 0.5, -2.0, height + 1.0)).astype(np.int64) + 1
        r0 = np.clip(r0, 0, height)
        counts = np.where(okf, np.maximum(np.clip(r1, 0, height) - r0, 0), 0)
        item, step = _expand(counts)
        row = r0[item] + step
        with np.errstate(over="ignore", invalid="ignore"):  # absurd coordinates give empty spans
            x_lo, x_hi = spans(item, (row + 0.5).astype(np.float64))
        n_spans = 1 if x_lo.ndim == 1 else x_lo.shape[1]
        x_lo, x_hi = x_lo.reshape(-1), x_hi.reshape(-1)
        if n_spans > 1:
            item, row = np.repeat(item, n_spans), np.repeat(row, n_spans)
        valid = ~(np.isnan(x_lo) | np.isnan(x_hi))
        c0 = np.ceil(np.clip(np.where(valid, x_lo, 0.0) - 0.5, -1.0, width + 1.0)).astype(np.int64)
        c1 = np.floor(np.clip(np.where(valid, x_hi, -1.0) - 0.5, -2.0, width + 1.0)).astype(np.int64) + 1
        c0 = np.clip(c0, 0, width)
        span_len = np.where(valid, np.maximum(np.clip(c1, 0, width) - c0, 0), 0)
        span, offset = _expand(span_len)
        rows, cols, items = row[span], c0[span] + offset, item[span]
        if always is not None:
            cand = np.flatnonzero(ok)
            pts = np.floor(np.clip(always[cand], -1.0, [width + 1.0, height + 1.0])).astype(np.int64)
            inb = (pts[:, 0] >= 0) & (pts[:, 0] < width) & (pts[:, 1] >= 0) & (pts[:, 1] < height)
            rows = np.concatenate([pts[inb, 1], rows])
            cols = np.concatenate([pts[inb, 0], cols])
            items = np.concatenate([cand[inb], items])
            order = np.argsort(items, kind="stable")
            rows, cols, items = rows[order], cols[order], items[order]
        # Pixels are in item order; with repeated indices numpy assigns the last value.
        self._image[rows, cols] = colors[items]

    def _segments_px(self, p0: FloatArray, p1: FloatArray, colors: ColorArray, thickness_px: float) -> None:
        """Draws segments given in continuous pixel coordinates (see :meth:`segments`)."""
        thick = max(round(float(thickness_px)), 1)
        ok = np.all(np.isfinite(p0), axis=1) & np.all(np.isfinite(p1), axis=1)
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return
        a, b = p0[idx], p1[idx]
        # Liang-Barsky clip to the canvas grown by the line width, so off-canvas parts cost nothing.
        pad = thick + 1.0
        d = b - a
        t0 = np.zeros(idx.size)
        t1 = np.ones(idx.size)
        keep = np.ones(idx.size, dtype=bool)
        bounds = ((0, -pad, -1.0), (0, self.width + pad, 1.0), (1, -pad, -1.0), (1, self.height + pad, 1.0))
        for axis, limit, sign in bounds:  # four clip edges
            p = sign * d[:, axis]
            q = sign * (limit - a[:, axis])
            parallel = p == 0
            keep &= ~(parallel & (q < 0))
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                t = q / np.where(parallel, 1.0, p)
            t0 = np.where(~parallel & (p < 0), np.maximum(t0, t), t0)
            t1 = np.where(~parallel & (p > 0), np.minimum(t1, t), t1)
        keep &= t0 <= t1
        idx, a, d, t0, t1 = idx[keep], a[keep], d[keep], t0[keep], t1[keep]
        if idx.size == 0:
            return
        start = a + t0[:, None] * d
        delta = (t1 - t0)[:, None] * d
        if thick > 1:
            length = np.hypot(delta[:, 0], delta[:, 1])
            safe = np.where(length > 0, length, 1.0)
            ux = np.where(length > 0, delta[:, 0] / safe, 1.0)
            uy = np.where(length > 0, delta[:, 1] / safe, 0.0)
            h = thick / 2.0
            along = np.stack([ux, uy], axis=1) * h
            across = np.stack([-uy, ux], axis=1) * h
            s0, s1 = start - along, start + delta + along
            quads = np.stack([s0 - across, s1 - across, s1 + across, s0 + across], axis=1)
            full = np.full((colors.shape[0], 4, 2), np.nan)
            full[idx] = quads
            self._polygons_px(full, colors)
            return
        # Samples at most 0.75 px apart: strictly below one pixel even after rounding, so no column
        # or row crossed by a segment is skipped.
        counts = np.ceil(np.hypot(delta[:, 0], delta[:, 1]) / 0.75).astype(np.int64) + 1
        seg, step = _expand(counts)
        frac = step / np.maximum(counts[seg] - 1, 1)
        pts = np.floor(start[seg] + frac[:, None] * delta[seg]).astype(np.int64)
        inb = (pts[:, 0] >= 0) & (pts[:, 0] < self.width) & (pts[:, 1] >= 0) & (pts[:, 1] < self.height)
        self._image[pts[inb, 1], pts[inb, 0]] = colors[idx[seg[inb]]]


def identity_colors(ids: ArrayLike) -> ColorArray:
    """Deterministic, well-separated RGB colours for integer identities.

    Hues step by the golden-ratio conjugate per id (consecutive ids get very different hues) and
    the brightness cycles through three levels, so nearby ids stay distinguishable.

    Args:
        ids: Integer ids, any shape (flattened); negative ids are allowed.

    Returns:
        ``uint8`` array (n, 3); equal ids give equal colours.
    """
    id_arr = np.asarray(ids, dtype=np.int64).reshape(-1)
    hue = np.mod(id_arr.astype(np.float64) * _GOLDEN + 0.11, 1.0)
    sat = np.where(np.mod(id_arr, 2) == 0, 0.75, 0.6)
    val = np.array([0.95, 0.78, 0.62])[np.mod(id_arr, 3)]
    h6 = hue * 6.0
    sector = np.floor(h6).astype(np.int64) % 6
    f = h6 - np.floor(h6)
    p = val * (1.0 - sat)
    q = val * (1.0 - sat * f)
    t = val * (1.0 - sat * (1.0 - f))
    r = np.choose(sector, [val, q, p, p, t, val])
    g = np.choose(sector, [t, val, val, q, p, p])
    b = np.choose(sector, [p, p, t, val, val, q])
    return np.clip(np.rint(np.stack([r, g, b], axis=1) * 255.0), 0, 255).astype(np.uint8)


class HumanWindow:
    """Shows RGB frames in a pygame window (for ``render_mode="human"``).

    The window is created lazily on the first :meth:`show`, sized to the frame. pygame is imported
    only then; with ``SDL_VIDEODRIVER=dummy`` it works headless.

    Args:
        title: Window caption.
        fps: Frame rate to hold :meth:`show` to (``<= 0``: no limit).
    """

    def __init__(self, title: str, fps: int) -> None:
        self.title = title
        self.fps = int(fps)
        self.quit_requested = False
        self._pygame: Any = None
        self._screen: Any = None
        self._clock: Any = None
        self._size: tuple[int, int] | None = None

    @staticmethod
    def _import_pygame() -> Any:
        """Imports pygame or raises :class:`gymnasium.error.DependencyNotInstalled`."""
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        try:
            import pygame
        except ImportError as exc:
            from gymnasium.error import DependencyNotInstalled

            raise DependencyNotInstalled(
                'pygame is not installed; run `pip install "track-envs[render]"`'
            ) from exc
        return pygame

    @property
    def is_open(self) -> bool:
        """Whether the window currently exists."""
        return self._screen is not None

    def show(self, frame: ArrayLike) -> None:
        """Displays one frame, pumps window events and waits to hold the frame rate.

        Args:
            frame: ``uint8`` image of shape (H, W, 3).

        Raises:
            gymnasium.error.DependencyNotInstalled: If pygame is not installed.
            ValueError: If ``frame`` is not (H, W, 3).
        """
        img = np.asarray(frame)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"expected an (H, W, 3) frame, got {img.shape}")
        if img.dtype != np.uint8:
            img = np.clip(img, 0, 255).astype(np.uint8)
        if self._pygame is None:
            self._pygame = self._import_pygame()
        pygame = self._pygame
        size = (int(img.shape[1]), int(img.shape[0]))
        if self._screen is None or self._size != size:
            if not pygame.display.get_init():
                pygame.init()
                pygame.display.init()
            self._screen = pygame.display.set_mode(size)
            pygame.display.set_caption(self.title)
            self._size = size
        if self._clock is None:
            self._clock = pygame.time.Clock()
        for event in pygame.event.get():
            if event.type == pygame.QUIT:
                self.quit_requested = True
        surface = pygame.surfarray.make_surface(np.ascontiguousarray(img.transpose(1, 0, 2)))
        self._screen.blit(surface, (0, 0))
        pygame.display.flip()
        self._clock.tick(max(self.fps, 0))

    def close(self) -> None:
        """Closes the window (safe to call repeatedly, or before any :meth:`show`)."""
        if self._pygame is not None and self._screen is not None:
            self._pygame.display.quit()
            self._pygame.quit()
        self._screen = None
        self._clock = None
        self._size = None
