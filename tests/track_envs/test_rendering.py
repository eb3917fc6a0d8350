"""Tests for the numpy rasteriser and the pygame human-mode window."""

from __future__ import annotations

import time

import numpy as np
import pytest

from track_envs.rendering import Canvas, HumanWindow, identity_colors

WHITE = np.array([255, 255, 255], dtype=np.uint8)
RED = np.array([255, 0, 0], dtype=np.uint8)
BLUE = np.array([0, 0, 255], dtype=np.uint8)


def make_canvas(width: int = 200, height: int = 100) -> Canvas:
    """A canvas over world [0, 2] x [0, 1] (100 pixels per world unit)."""
    return Canvas(width, height, (0.0, 0.0), (2.0, 1.0))


def colored(canvas: Canvas) -> np.ndarray:
    """Boolean (H, W) mask of pixels that differ from the white background."""
    return np.any(canvas.image != WHITE, axis=2)


def test_shapes_and_dtypes() -> None:
    canvas = make_canvas()
    assert canvas.image.shape == (100, 200, 3)
    assert canvas.image.dtype == np.uint8
    arr = canvas.to_array()
    assert arr.shape == (100, 200, 3)
    assert arr.dtype == np.uint8
    assert np.all(arr == 255)
    arr[0, 0] = 0  # to_array is a copy
    assert np.all(canvas.image[0, 0] == 255)
    pix = canvas.to_pixels(np.array([[0.0, 0.0], [2.0, 1.0], [1.0, 0.5]]))
    assert pix.shape == (3, 2)
    assert pix.dtype == np.float64
    np.testing.assert_allclose(pix, [[0.0, 100.0], [200.0, 0.0], [100.0, 50.0]])


def test_background_and_clear() -> None:
    canvas = Canvas(10, 5, (0.0, 0.0), (1.0, 1.0), background=(10, 20, 30))
    assert np.all(canvas.image == [10, 20, 30])
    canvas.discs([[0.5, 0.5]], 2, RED)
    canvas.clear()
    assert np.all(canvas.image == [10, 20, 30])


def test_disc_colours_expected_pixel_only() -> None:
    canvas = make_canvas()
    canvas.discs(np.array([[0.505, 0.505]]), 3.0, RED)
    col, row = canvas.to_pixels(np.array([0.505, 0.505]))[0]
    assert (int(col), int(row)) == (50, 49)
    assert np.array_equal(canvas.image[49, 50], RED)
    mask = colored(canvas)
    rows, cols = np.nonzero(mask)
    assert rows.min() >= 49 - 4 and rows.max() <= 49 + 4
    assert cols.min() >= 50 - 4 and cols.max() <= 50 + 4
    assert not mask[0, 0] and not mask[99, 199] and not mask[49, 150]
    assert 20 <= mask.sum() <= 40  # about pi * 3^2


def test_disc_min_radius_and_per_item_colours_and_radii() -> None:
    canvas = make_canvas()
    canvas.discs([[0.305, 0.505], [1.505, 0.505]], np.array([0.1, 5.0]), np.stack([RED, BLUE]))
    assert np.array_equal(canvas.image[49, 30], RED)
    assert np.array_equal(canvas.image[49, 150], BLUE)
    assert np.array_equal(canvas.image[49, 154], BLUE)
    assert np.array_equal(canvas.image[49, 34], WHITE)


def test_y_up_orientation() -> None:
    canvas = make_canvas()
    canvas.discs([[1.0, 0.98]], 1.0, RED)
    rows, _ = np.nonzero(colored(canvas))
    assert rows.size > 0 and rows.max() < 5
    canvas.clear()
    canvas.discs([[1.0, 0.02]], 1.0, RED)
    rows, _ = np.nonzero(colored(canvas))
    assert rows.size > 0 and rows.min() > 94


def test_off_canvas_and_nan_points_do_not_draw() -> None:
    canvas = make_canvas()
    far = np.array([[-5.0, 0.5], [10.0, 0.5], [1.0, -3.0], [1.0, 7.0], [np.nan, 0.5], [0.5, np.nan]])
    far_big = np.array([[1e300, 1e300], [-np.inf, 0.5]])
    canvas.discs(far, 4.0, RED)
    canvas.discs(far_big, 4.0, RED)
    canvas.rings(far, 4.0, RED, thickness_px=2)
    canvas.crosses(far, 6, RED)
    canvas.crosses(far, 6, RED, style="+")
    canvas.segments(far, far[::-1] + 100.0, RED)
    canvas.segments(far_big, far_big[::-1], RED, thickness_px=3)
    canvas.segments(np.array([[np.nan, 0.5]]), np.array([[1.0, 0.5]]), RED)
    canvas.polygons(far[:, None, :] + np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]]), RED)
    canvas.fill_rect((5.0, 5.0), (6.0, 6.0), RED)
    canvas.fill_rect((np.nan, 0.0), (1.0, 1.0), RED)
    canvas.discs(np.zeros((0, 2)), 3.0, RED)
    canvas.polygons(np.zeros((0, 4, 2)), RED)
    canvas.discs([[1.7e308, -1.7e308]], 3.0, RED)
    canvas.polygons(np.array([[[1e300, 1e300], [1e300, 2e300], [2e300, 1e300]]]), RED)
    canvas.segments(np.zeros((0, 2)), np.zeros((0, 2)), RED)
    assert not colored(canvas).any()


def test_partly_off_canvas_items_are_clipped() -> None:
    canvas = make_canvas()
    canvas.discs([[0.0, 0.0]], 10.0, RED)
    canvas.segments([[-1.0, 0.5]], [[3.0, 0.5]], BLUE)
    mask = colored(canvas)
    assert np.array_equal(canvas.image[99, 0], RED)
    assert mask[50].all()  # the horizontal line spans the whole image


def test_polygon_covers_centre_not_outside_box() -> None:
    canvas = make_canvas()
    angle = 0.4
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    half = np.array([[-0.1, -0.05], [0.1, -0.05], [0.1, 0.05], [-0.1, 0.05]])
    centre = np.array([1.0, 0.5])
    verts = centre + half @ rot.T
    canvas.polygons(verts[None], BLUE)
    col, row = canvas.to_pixels(centre)[0]
    assert np.array_equal(canvas.image[int(row), int(col)], BLUE)
    pix = canvas.to_pixels(verts)
    lo = np.floor(pix.min(axis=0)).astype(int)
    hi = np.floor(pix.max(axis=0)).astype(int)
    rows, cols = np.nonzero(colored(canvas))
    assert cols.min() >= lo[0] and cols.max() <= hi[0]
    assert rows.min() >= lo[1] and rows.max() <= hi[1]
    # Area close to the true 20 x 10 px rectangle; corners of the bounding box stay empty.
    assert abs(rows.size - 200) <= 30
    assert not colored(canvas)[lo[1], lo[0]]


def test_polygon_rotation_follows_y_up() -> None:
    canvas = Canvas(200, 200, (0.0, 0.0), (1.0, 1.0))
    angle = np.pi / 4  # counter-clockwise in the world: the long axis points up and to the right
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    half = np.array([[-0.2, -0.02], [0.2, -0.02], [0.2, 0.02], [-0.2, 0.02]])
    canvas.polygons(0.5 + half @ rot.T, RED)
    assert np.array_equal(canvas.image[80, 120], RED)  # up-right of the centre pixel (100, 100)
    assert np.array_equal(canvas.image[80, 80], WHITE)  # up-left


def test_polygons_either_winding_and_tiny() -> None:
    canvas = make_canvas()
    square = np.array([[0.2, 0.2], [0.4, 0.2], [0.4, 0.4], [0.2, 0.4]])
    tiny = np.array([[1.5, 0.5], [1.501, 0.5], [1.501, 0.501], [1.5, 0.501]])
    canvas.polygons(np.stack([square[::-1] + np.array([1.0, 0.0]), square, tiny]), np.stack([RED, BLUE, RED]))
    assert np.array_equal(canvas.image[70, 30], BLUE)
    assert np.array_equal(canvas.image[70, 130], RED)
    col, row = canvas.to_pixels(tiny.mean(axis=0))[0]
    assert np.array_equal(canvas.image[int(row), int(col)], RED)


def test_segments_are_connected() -> None:
    canvas = make_canvas()
    canvas.segments([[0.105, 0.505]], [[1.805, 0.505]], RED)
    assert np.all(canvas.image[49, 10:181] == RED)
    assert colored(canvas).sum() == 171
    # A steep diagonal is 8-connected: every row between the endpoints has a pixel.
    canvas.clear()
    canvas.segments([[0.5, 0.05]], [[0.9, 0.95]], BLUE)
    rows, cols = np.nonzero(colored(canvas))
    assert set(range(5, 96)) <= set(rows.tolist())
    order = np.argsort(rows)
    assert np.all(np.abs(np.diff(cols[order])) <= 1)


def test_thick_segments_rings_and_crosses() -> None:
    canvas = make_canvas()
    canvas.segments([[0.1, 0.505]], [[1.9, 0.505]], RED, thickness_px=3)
    assert np.all(canvas.image[48:51, 20:180] == RED)
    canvas.clear()
    canvas.rings([[1.005, 0.505]], 10.0, BLUE)
    assert np.array_equal(canvas.image[49, 100], WHITE)  # hollow
    assert np.array_equal(canvas.image[49, 110], BLUE)
    assert np.array_equal(canvas.image[39, 100], BLUE)
    canvas.clear()
    canvas.crosses([[1.005, 0.505]], 8, RED)
    assert np.array_equal(canvas.image[49, 100], RED)
    assert np.array_equal(canvas.image[46, 97], RED)
    assert np.array_equal(canvas.image[46, 100], WHITE)
    canvas.clear()
    canvas.crosses([[1.005, 0.505]], 8, RED, style="+")
    assert np.array_equal(canvas.image[46, 100], RED)
    assert np.array_equal(canvas.image[46, 97], WHITE)


def test_fill_rect_and_paint_order() -> None:
    canvas = make_canvas()
    canvas.fill_rect((0.5, 0.0), (1.0, 0.5), RED)
    mask = colored(canvas)
    assert mask[50:100, 50:100].all()
    assert mask.sum() == 50 * 50
    canvas.discs([[1.0, 0.5], [1.0, 0.5]], [5.0, 2.0], np.stack([RED, BLUE]))
    assert np.array_equal(canvas.image[50, 100], BLUE)  # the later item is on top


def test_bad_shapes_raise() -> None:
    canvas = make_canvas()
    with pytest.raises(ValueError):
        canvas.discs(np.zeros((3, 3)), 2.0, RED)
    with pytest.raises(ValueError):
        canvas.discs(np.zeros((3, 2)), 2.0, np.zeros((2, 3)))
    with pytest.raises(ValueError):
        canvas.polygons(np.zeros((3, 2, 2)), RED)
    with pytest.raises(ValueError):
        Canvas(10, 10, (1.0, 0.0), (0.0, 1.0))


def test_identity_colors_deterministic_and_distinct() -> None:
    ids = np.arange(21)
    colors = identity_colors(ids)
    assert colors.shape == (21, 3)
    assert colors.dtype == np.uint8
    assert np.array_equal(colors, identity_colors(ids))
    assert np.array_equal(identity_colors([7, 3, 7])[[0, 2]], identity_colors([7, 7]))
    assert len({tuple(c) for c in colors.tolist()}) == 21
    diff = np.abs(colors[:, None, :].astype(int) - colors[None, :, :].astype(int)).sum(axis=2)
    assert diff[~np.eye(21, dtype=bool)].min() >= 20
    assert identity_colors(np.array([-1, 10**9])).shape == (2, 3)


def test_human_window_headless(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    window = HumanWindow("test", fps=1000)
    window.close()  # closing before any show is fine
    canvas = make_canvas()
    canvas.discs([[1.0, 0.5]], 5.0, RED)
    window.show(canvas.image)
    assert window.is_open
    window.show(canvas.to_array())
    window.show(np.zeros((50, 60, 3), dtype=np.uint8))  # a new frame size resizes the window
    window.close()
    assert not window.is_open
    window.close()
    window.show(canvas.image)  # reopening after close works
    window.close()
    window.close()


def test_human_window_missing_pygame(monkeypatch: pytest.MonkeyPatch) -> None:
    import builtins

    from gymnasium.error import DependencyNotInstalled

    real_import = builtins.__import__

    def fake_import(name: str, *args: object, **kwargs: object) -> object:
        if name == "pygame" or name.startswith("pygame."):
            raise ImportError("no pygame")
        return real_import(name, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(builtins, "__import__", fake_import)
    window = HumanWindow("test", fps=30)
    with pytest.raises(DependencyNotInstalled, match="pip install"):
        window.show(np.zeros((4, 4, 3), dtype=np.uint8))
    window.close()


def test_timing_300_discs_and_polygons() -> None:
    rng = np.random.default_rng(0)
    canvas = Canvas(800, 400, (0.0, 0.0), (2.0, 1.0), background=(30, 30, 30))
    n = 300
    centres = rng.uniform([0.0, 0.0], [2.0, 1.0], size=(n, 2))
    radii = rng.uniform(2.0, 8.0, size=n)
    angles = rng.uniform(0.0, np.pi, size=n)
    half = np.array([[-0.012, -0.006], [0.012, -0.006], [0.012, 0.006], [-0.012, 0.006]])
    cos, sin = np.cos(angles)[:, None], np.sin(angles)[:, None]
    verts = np.stack(
        [cos * half[:, 0] - sin * half[:, 1], sin * half[:, 0] + cos * half[:, 1]], axis=-1
    ) + rng.uniform([0.0, 0.0], [2.0, 1.0], size=(n, 1, 2))
    colors = identity_colors(np.arange(n))
    canvas.discs(centres, radii, colors)  # warm-up
    canvas.polygons(verts, colors)
    reps = 20
    start = time.perf_counter()
    for _ in range(reps):
        canvas.clear()
        canvas.discs(centres, radii, colors)
        canvas.polygons(verts, colors)
    elapsed = (time.perf_counter() - start) / reps
    print(f"\n800x400 canvas, {n} discs + {n} polygons: {elapsed * 1e3:.2f} ms per frame")
    assert colored_frac(canvas) > 0.05


def colored_frac(canvas: Canvas) -> float:
    """Fraction of pixels differing from the canvas background."""
    return float(np.mean(np.any(canvas.image != canvas.background, axis=2)))
