"""Frames for the environments' ``render()``: Pillow's ``ImageDraw`` behind a world-to-pixel map.

A [`Canvas`][track_envs.envs.Canvas] shows the world box ``[world_low, world_high]`` (x to the right, y
**up**) in a scene of ``width × height`` pixels, above a footer strip that carries the caption (frame number
and time) and the legend ([`LegendEntry`][track_envs.envs.LegendEntry]).
[`WorldToPixel`][track_envs.envs.WorldToPixel] is the map between the two coordinate systems;
[`Canvas.to_array`][track_envs.envs.Canvas.to_array] gives the ``uint8`` frame of shape
``(height + footer_height, width, 3)``. No display is needed (``render_mode="human"`` shows the frames with
[`track_envs.envs.render_window.HumanWindow`][track_envs.envs.render_window.HumanWindow]).

Drawing methods take ``n`` world points (or segments, polygons) and one colour or ``n`` colours.
Items with a non-finite coordinate, or farther than a million pixels off the scene, are skipped;
Pillow clips the rest to the image. Later items paint over earlier ones; the footer is painted
last, over anything that spilled past the scene's lower edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from PIL import Image, ImageDraw, ImageFont

__all__ = ["Canvas", "LegendEntry", "WorldToPixel", "footer_height", "identity_colors"]

Color = tuple[int, int, int]
Marker = Literal["disc", "box", "ring", "cross", "line", "outlined-line"]
_MARKERS = ("disc", "box", "ring", "cross", "line", "outlined-line")
_Font = ImageFont.FreeTypeFont | ImageFont.ImageFont

FOOTER_BACKGROUND: Color = (250, 250, 250)
FOOTER_TEXT: Color = (20, 20, 20)
FOOTER_RULE: Color = (110, 110, 110)

_GOLDEN = 0.6180339887498949  # golden-ratio conjugate: hue step between consecutive ids
_FAR_PX = 1e6  # items beyond this many pixels are skipped (Pillow takes C integers)
_LEGEND_IDS = (1, 2, 3)  # the identities whose colours stand for "colour = id" in the legend


class WorldToPixel:
    """The affine map from world points (x right, y up) to pixel coordinates (column right, row down).

    With the scale ``s = (width, height) / (world_high − world_low)`` per axis,

        col = (x − x_low) · s_x,    row = (y_high − y) · s_y,

    so ``world_low`` is the bottom-left corner of the scene and ``world_high`` its top-right corner.
    Pixel ``[i, j]`` of the frame covers ``row ∈ [i, i + 1)``, ``col ∈ [j, j + 1)``: a point is
    drawn centred on the pixel ``(⌊row⌋, ⌊col⌋)`` ([`pixel`][track_envs.envs.WorldToPixel.pixel]).

    Args:
        width: Scene width in pixels (>= 1).
        height: Scene height in pixels (>= 1).
        world_low: World ``(x, y)`` of the scene's bottom-left corner.
        world_high: World ``(x, y)`` of the scene's top-right corner; above ``world_low`` on both axes.
    """

    def __init__(self, width: int, height: int, world_low: ArrayLike, world_high: ArrayLike) -> None:
        if int(width) < 1 or int(height) < 1:
            raise ValueError(f"scene size must be at least 1x1 pixels, got {width}x{height}")
        self.width = int(width)
        self.height = int(height)
        self.low = np.asarray(world_low, dtype=np.float64).reshape(2)
        self.high = np.asarray(world_high, dtype=np.float64).reshape(2)
        span = self.high - self.low
        if not (np.all(np.isfinite(span)) and np.all(span > 0)):
            raise ValueError(
                f"world_high must exceed world_low on both axes, got {tuple(self.low)} and {tuple(self.high)}"
            )
        self.scale = np.array([self.width, self.height], dtype=np.float64) / span

    def __call__(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pixel coordinates ``(col, row)`` of world points of shape (..., 2) (same shape back)."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape[-1:] != (2,):
            raise ValueError(f"expected world points of shape (..., 2), got {pts.shape}")
        out = np.empty_like(pts)
        with np.errstate(over="ignore", invalid="ignore"):
            out[..., 0] = (pts[..., 0] - self.low[0]) * self.scale[0]
            out[..., 1] = (self.high[1] - pts[..., 1]) * self.scale[1]
        return out

    def to_world(self, pixels: ArrayLike) -> NDArray[np.float64]:
        """World points of pixel coordinates ``(col, row)`` of shape (..., 2): the inverse map
        (``to_world((j + 0.5, i + 0.5))`` is the centre of pixel ``[i, j]``)."""
        pix = np.asarray(pixels, dtype=np.float64)
        out = np.empty_like(pix)
        out[..., 0] = self.low[0] + pix[..., 0] / self.scale[0]
        out[..., 1] = self.high[1] - pix[..., 1] / self.scale[1]
        return out

    def pixel(self, point: ArrayLike) -> tuple[int, int]:
        """The frame index ``(row, col)`` of the pixel holding world ``point`` (2,)."""
        col, row = np.floor(self(np.asarray(point, dtype=np.float64).reshape(2)))
        return int(row), int(col)


@dataclass(frozen=True)
class LegendEntry:
    """One legend item: a marker drawn as the scene draws it, and a label.

    Attributes:
        label: Text after the marker (e.g. ``"truth"``).
        marker: ``"disc"``, ``"box"``, ``"ring"``, ``"cross"``, ``"line"`` or ``"outlined-line"``
            (a coloured line on a black one).
        color: The marker's RGB colour, or ``None`` when the scene colours each item by its
            identity (`identity_colors`); the legend then shows
            three identities' colours.
    """

    label: str
    marker: Marker
    color: Color | None = None

    def __post_init__(self) -> None:
        if self.marker not in _MARKERS:
            raise ValueError(f"legend marker must be one of {_MARKERS}, got {self.marker!r}")
        if self.color is not None:
            object.__setattr__(self, "color", _colors(self.color, 1)[0])


def identity_colors(ids: ArrayLike) -> NDArray[np.uint8]:
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


def _colors(color: ArrayLike, n: int) -> list[Color]:
    """One RGB tuple per item from a (3,) or (n, 3) colour spec (values clipped to 0..255)."""
    arr = np.asarray(color)
    if arr.shape != (3,) and arr.shape != (n, 3):
        raise ValueError(f"expected an RGB colour of shape (3,) or ({n}, 3), got {arr.shape}")
    arr = np.clip(np.rint(arr.astype(np.float64)), 0, 255).astype(np.int64)
    return [tuple(c) for c in np.broadcast_to(arr, (n, 3)).tolist()]


def _drawable(pix: NDArray[np.float64], item_axes: tuple[int, ...]) -> NDArray[np.bool_]:
    """Items whose pixel coordinates are all finite and within ``_FAR_PX`` of the image."""
    with np.errstate(invalid="ignore"):
        return np.all(np.isfinite(pix) & (np.abs(pix) < _FAR_PX), axis=item_axes)


def _floor(pix: NDArray[np.float64]) -> NDArray[np.float64]:
    """The pixel each continuous coordinate falls in (NaN and inf stay, to be skipped)."""
    with np.errstate(invalid="ignore"):
        return np.floor(pix)


def _per_item(value: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"expected {name} as a scalar or of shape ({n},), got {arr.shape}")
    return arr


@lru_cache(maxsize=8)
def _font(size: int) -> _Font:
    """Pillow's bundled font at ``size`` pixels (its fixed bitmap font where FreeType is missing)."""
    return ImageFont.load_default(size=size)


def footer_height(width: int) -> int:
    """Height in pixels of the footer under a scene ``width`` pixels wide (even, for video codecs)."""
    return 2 * _font_size(width)


def _font_size(width: int) -> int:
    return int(np.clip(round(width / 64), 13, 18))


class Canvas:
    """A frame under construction: a scene in world coordinates, and a footer (caption, legend).

    Args:
        width: Scene width in pixels.
        height: Scene height in pixels (the frame is
            `footer_height` taller).
        world_low: World ``(x, y)`` of the scene's bottom-left corner.
        world_high: World ``(x, y)`` of the scene's top-right corner.
        background: RGB colour of the scene.

    Attributes:
        to_px: The [`WorldToPixel`][track_envs.envs.WorldToPixel] map of the scene.
        image: The Pillow image being drawn on.

    Example:
        >>> canvas = Canvas(200, 100, (0.0, 0.0), (2.0, 1.0))
        >>> canvas.discs([[1.0, 0.5]], 4, (255, 0, 0))
        >>> canvas.footer("frame 0", [LegendEntry("truth", "disc", (255, 0, 0))])
        >>> canvas.to_array().shape
        (126, 200, 3)
    """

    @classmethod
    def for_region(cls, spec: Any, width: int = 900, background: ArrayLike = (150, 150, 150)) -> Canvas:
        """A canvas of the sensor region of ``spec`` (a SensorSpec), ``width`` px wide, its height
        following the region's aspect ratio (clipped to 100–900 px)."""
        lo = np.asarray(spec.region_low, dtype=np.float64)
        hi = np.asarray(spec.region_high, dtype=np.float64)
        size = hi - lo
        height = int(np.clip(round(width * size[1] / size[0]), 100, 900))
        return cls(width, height, tuple(lo), tuple(hi), background)

    def __init__(
        self,
        width: int,
        height: int,
        world_low: ArrayLike,
        world_high: ArrayLike,
        background: ArrayLike = (255, 255, 255),
    ) -> None:
        self.to_px = WorldToPixel(width, height, world_low, world_high)
        self.width, self.height = self.to_px.width, self.to_px.height
        self.footer_height = footer_height(self.width)
        self.background = _colors(background, 1)[0]
        self.image = Image.new("RGB", (self.width, self.height + self.footer_height), self.background)
        self._draw = ImageDraw.Draw(self.image)

    @property
    def world_low(self) -> NDArray[np.float64]:
        """World ``(x, y)`` of the scene's bottom-left corner."""
        return self.to_px.low

    @property
    def world_high(self) -> NDArray[np.float64]:
        """World ``(x, y)`` of the scene's top-right corner."""
        return self.to_px.high

    def to_array(self) -> NDArray[np.uint8]:
        """The frame as a new ``uint8`` array of shape ``(height + footer_height, width, 3)``."""
        return np.array(self.image, dtype=np.uint8)

    # ------------------------------------------------------------------ scene, world coordinates

    def fill_rect(self, low: ArrayLike, high: ArrayLike, color: ArrayLike) -> None:
        """Fills the pixels whose centres lie in the axis-aligned world rectangle ``[low, high]``."""
        corners = self.to_px(np.stack([np.asarray(low, float), np.asarray(high, float)]))
        if _drawable(corners, (0, 1)):
            (x0, y0), (x1, y1) = np.rint(np.sort(corners, axis=0)).astype(np.int64).tolist()
            if x1 > x0 and y1 > y0:
                self._draw.rectangle((x0, y0, x1 - 1, y1 - 1), fill=_colors(color, 1)[0])

    def discs(self, centers: ArrayLike, radius_px: ArrayLike, color: ArrayLike) -> None:
        """Filled discs of ``radius_px`` (scalar or (n,); rounded, at least 1) around world
        ``centers`` (n, 2)."""
        self._round(centers, radius_px, color, fill=True, width=1)

    def rings(
        self, centers: ArrayLike, radius_px: ArrayLike, color: ArrayLike, thickness_px: int = 1
    ) -> None:
        """Circle outlines of ``radius_px`` (scalar or (n,)) around world ``centers`` (n, 2); the
        line, ``thickness_px`` wide, lies inside the radius."""
        self._round(centers, radius_px, color, fill=False, width=thickness_px)

    def crosses(
        self,
        points: ArrayLike,
        size_px: float,
        color: ArrayLike,
        style: Literal["x", "+"] = "x",
        thickness_px: int = 1,
    ) -> None:
        """Markers ``x`` (diagonal) or ``+`` of full width ``size_px`` at world ``points`` (n, 2)."""
        if style not in ("x", "+"):
            raise ValueError(f"style must be 'x' or '+', got {style!r}")
        pix = self.to_px(np.asarray(points, dtype=np.float64).reshape(-1, 2))
        h = max(round(float(size_px) / 2), 1)
        arms = (
            [[[-h, -h], [h, h]], [[-h, h], [h, -h]]]
            if style == "x"
            else [[[-h, 0], [h, 0]], [[0, -h], [0, h]]]
        )
        ends = _floor(pix)[:, None, None, :] + np.array(arms)[None]  # (n, arm, end, 2)
        colors = [c for c in _colors(color, len(pix)) for _ in range(2)]
        self._lines_px(ends.reshape(-1, 2, 2), colors, thickness_px)

    def segments(self, p0: ArrayLike, p1: ArrayLike, color: ArrayLike, thickness_px: int = 1) -> None:
        """Line segments from world ``p0[i]`` to ``p1[i]`` (each (n, 2)), ``thickness_px`` wide."""
        a = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
        b = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
        if a.shape != b.shape:
            raise ValueError(f"p0 and p1 must have the same shape, got {a.shape} and {b.shape}")
        ends = _floor(self.to_px(np.stack([a, b], axis=1)))
        self._lines_px(ends, _colors(color, len(a)), thickness_px)

    def polygons(self, vertices: ArrayLike, color: ArrayLike) -> None:
        """Filled polygons with world ``vertices`` (n, k, 2), ``k >= 3`` (one (k, 2) polygon accepted)."""
        verts = np.asarray(vertices, dtype=np.float64)
        if verts.ndim == 2:
            verts = verts[None]
        if verts.ndim != 3 or verts.shape[2] != 2 or verts.shape[1] < 3:
            raise ValueError(f"expected polygon vertices of shape (n, k>=3, 2), got {verts.shape}")
        pix = _floor(self.to_px(verts))
        colors = _colors(color, len(verts))
        draw = self._draw
        for i in np.flatnonzero(_drawable(pix, (1, 2))).tolist():
            draw.polygon(pix[i].reshape(-1).tolist(), fill=colors[i])

    # ------------------------------------------------------------------ footer

    def footer(self, caption: str, legend: Sequence[LegendEntry] = ()) -> None:
        """Paints the footer: ``caption`` at the left, the ``legend`` entries at the right.

        Call it after the scene is drawn: it paints over anything that spilled past the scene.
        """
        draw, top, w = self._draw, self.height, self.width
        size = _font_size(w)
        font = _font(size)
        draw.rectangle((0, top, w - 1, top + self.footer_height - 1), fill=FOOTER_BACKGROUND)
        draw.line((0, top, w - 1, top), fill=FOOTER_RULE, width=1)
        pad = size // 2
        _text(draw, pad, top + self.footer_height / 2, caption, font)
        if legend:
            strip = _legend_strip(tuple(legend), size, self.footer_height - 1)
            x = max(w - pad - strip.width, pad + draw.textlength(caption, font=font) + 2 * size)
            self.image.paste(strip, (round(x), top + 1))

    # ------------------------------------------------------------------ internals

    def _round(
        self, centers: ArrayLike, radius_px: ArrayLike, color: ArrayLike, fill: bool, width: int
    ) -> None:
        """Discs (``fill``) or rings of ``width`` centred on the pixels holding ``centers``."""
        pix = _floor(self.to_px(np.asarray(centers, dtype=np.float64).reshape(-1, 2)))
        n = len(pix)
        r = np.maximum(np.rint(_per_item(radius_px, n, "radius_px")), 1.0)
        boxes = np.concatenate([pix - r[:, None], pix + r[:, None]], axis=1)  # inclusive corners
        ok = _drawable(boxes, (1,))
        colors = _colors(color, n)
        draw, w = self._draw, max(int(width), 1)
        for i, box in zip(np.flatnonzero(ok).tolist(), boxes[ok].astype(np.int64).tolist(), strict=True):
            if fill:
                draw.ellipse(box, fill=colors[i])
            else:
                draw.ellipse(box, outline=colors[i], width=w)

    def _lines_px(self, ends: NDArray[np.float64], colors: list[Color], width: int) -> None:
        """Draws segments between pixels (n, 2, 2) (integer-valued), ``colors[i]`` for segment ``i``."""
        ok = _drawable(ends, (1, 2))
        draw, w = self._draw, max(int(width), 1)
        segments = ends[ok].reshape(-1, 4).astype(np.int64).tolist()
        for i, seg in zip(np.flatnonzero(ok).tolist(), segments, strict=True):
            draw.line(seg, fill=colors[i], width=w)


def _text(draw: ImageDraw.ImageDraw, x: float, mid: float, text: str, font: _Font) -> None:
    """Writes ``text`` from ``x``, centred vertically on ``mid``."""
    _, top, _, bottom = draw.textbbox((0, 0), text, font=font)
    draw.text((x, mid - (top + bottom) / 2), text, fill=FOOTER_TEXT, font=font)


def _marker_width(entry: LegendEntry, size: int) -> int:
    """Width of ``entry``'s marker: one glyph of ``size`` pixels, or three overlapping ones."""
    return size if entry.color is not None else 3 * size - size // 2


@lru_cache(maxsize=32)
def _legend_strip(legend: tuple[LegendEntry, ...], size: int, height: int) -> Image.Image:
    """The legend, markers and labels in a row, on the footer's background (cached: it is static)."""
    font = _font(size)
    pad, gap = size // 2, size
    scratch = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    widths = [_marker_width(e, size) + pad // 2 + scratch.textlength(e.label, font=font) for e in legend]
    total = round(sum(widths) + gap * (len(legend) - 1))
    strip = Image.new("RGB", (max(total, 1), height), FOOTER_BACKGROUND)
    draw = ImageDraw.Draw(strip)
    x, mid = 0.0, height / 2
    for entry, width in zip(legend, widths, strict=True):
        _marker(draw, entry, x, mid, size)
        _text(draw, x + _marker_width(entry, size) + pad // 2, mid, entry.label, font)
        x += width + gap
    return strip


def _marker(draw: ImageDraw.ImageDraw, entry: LegendEntry, x: float, mid: float, size: int) -> None:
    """Draws ``entry``'s marker from ``x``, centred on ``mid``, in glyphs of ``size`` pixels."""
    if entry.color is not None:
        colors, step = [entry.color], 0
    else:  # colour = identity: three identities' colours, overlapping
        colors, step = _colors(identity_colors(_LEGEND_IDS), len(_LEGEND_IDS)), size - size // 4
    h = size / 2 - 1
    for k, c in enumerate(colors):
        cx = x + size / 2 + k * step
        box = (cx - h, mid - h, cx + h, mid + h)
        diagonal = (cx - h, mid + h / 2, cx + h, mid - h / 2)
        if entry.marker == "disc":
            draw.ellipse(box, fill=c)
        elif entry.marker == "box":
            draw.rectangle((cx - h, mid - h / 2, cx + h, mid + h / 2), fill=c)
        elif entry.marker == "ring":
            draw.ellipse(box, outline=c, width=2)
        elif entry.marker == "cross":
            draw.line((cx - h / 2, mid - h / 2, cx + h / 2, mid + h / 2), fill=c, width=1)
            draw.line((cx - h / 2, mid + h / 2, cx + h / 2, mid - h / 2), fill=c, width=1)
        elif entry.marker == "line":
            draw.line(diagonal, fill=c, width=3)
        else:  # outlined-line
            draw.line(diagonal, fill=(0, 0, 0), width=3)
            draw.line(diagonal, fill=c, width=1)
