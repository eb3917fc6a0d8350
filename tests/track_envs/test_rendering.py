"""Behaviour of the frames ``render()`` draws: the world-to-pixel map, what is drawn where in which
colour, the footer (frame number, time, legend), empty scenes, and the pygame window."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from track_envs.contracts.report import empty_report, pack_report
from track_envs.envs.rendering import Canvas, LegendEntry, WorldToPixel, footer_height, identity_colors
from track_envs.io.wide_tracks import write_track_csv

RED = (255, 0, 0)
WHITE = (255, 255, 255)


def scene_of(env: gym.Env, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray, Canvas]:
    """The scene and footer parts of ``frame``, and a canvas of the env (for its pixel map)."""
    canvas = env.unwrapped._canvas()
    assert frame.shape == (canvas.height + canvas.footer_height, canvas.width, 3)
    return frame[: canvas.height], frame[canvas.height :], canvas


def legend_color(env: gym.Env, label: str) -> tuple[int, int, int] | None:
    return next(e.color for e in env.unwrapped._legend() if e.label == label)


# ---------------------------------------------------------------------------- the pixel map


def test_world_to_pixel_puts_world_low_bottom_left_and_y_up() -> None:
    to_px = WorldToPixel(200, 100, (0.0, 0.0), (2.0, 1.0))
    np.testing.assert_allclose(to_px([[0.0, 0.0], [2.0, 1.0]]), [[0.0, 100.0], [200.0, 0.0]])
    assert to_px.pixel((0.004, 0.004)) == (99, 0)  # bottom-left pixel
    assert to_px.pixel((1.996, 0.996)) == (0, 199)  # top-right pixel
    assert to_px.pixel((1.0, 0.9))[0] < to_px.pixel((1.0, 0.1))[0]  # higher y, smaller row
    assert to_px(np.zeros((3, 4, 2))).shape == (3, 4, 2)
    points = np.array([[0.3, 0.7], [1.234, 0.01]])
    np.testing.assert_allclose(to_px.to_world(to_px(points)), points)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((0, 10, (0, 0), (1, 1)), "1x1"),
        ((10, 10, (1, 0), (0, 1)), "world_high"),
        ((10, 10, (0, 0), (1, np.nan)), "world_high"),
    ],
)
def test_world_to_pixel_rejects_bad_scenes(args: tuple, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        WorldToPixel(*args)


# ---------------------------------------------------------------------------- the canvas


def test_canvas_frame_is_uint8_scene_over_footer() -> None:
    canvas = Canvas(200, 100, (0.0, 0.0), (2.0, 1.0), background=(10, 20, 30))
    canvas.footer("frame 0", [LegendEntry("truth", "disc", RED)])
    frame = canvas.to_array()
    assert frame.dtype == np.uint8
    assert frame.shape == (100 + footer_height(200), 200, 3) == (100 + canvas.footer_height, 200, 3)
    assert canvas.footer_height % 2 == 0
    assert np.all(frame[:100] == (10, 20, 30))  # nothing drawn: the scene is its background
    assert (frame[100:] != (10, 20, 30)).any()
    frame[0, 0] = 0
    assert np.all(canvas.to_array()[0, 0] == (10, 20, 30))  # to_array is a copy


def test_each_primitive_colours_the_pixel_the_map_gives() -> None:
    canvas = Canvas(200, 100, (0.0, 0.0), (2.0, 1.0), background=WHITE)
    ring_at = canvas.to_px.to_world((80.5, 50.5))  # the centre of pixel [50, 80]
    canvas.discs([[0.3, 0.5]], 4, RED)
    canvas.rings([ring_at], 6, (0, 0, 255), thickness_px=2)
    canvas.crosses([[1.2, 0.5]], 6, (0, 128, 0))
    canvas.polygons([[[1.5, 0.4], [1.7, 0.4], [1.7, 0.6], [1.5, 0.6]]], (200, 100, 0))
    canvas.segments([[0.1, 0.1]], [[1.9, 0.1]], (50, 50, 50), thickness_px=3)
    canvas.fill_rect((1.85, 0.8), (1.95, 0.9), (0, 200, 200))
    img = canvas.to_array()
    at = canvas.to_px.pixel
    assert tuple(img[at((0.3, 0.5))]) == RED
    assert at(ring_at) == (50, 80)
    assert tuple(img[50, 80]) == WHITE  # a ring is hollow, 2 px wide inside its radius
    assert {tuple(img[50, 80 + d]) for d in (-6, -5, 5, 6)} == {(0, 0, 255)}
    assert {tuple(img[50 + d, 80]) for d in (-6, -5, 5, 6)} == {(0, 0, 255)}
    assert tuple(img[at((1.2, 0.5))]) == (0, 128, 0)
    assert tuple(img[at((1.6, 0.5))]) == (200, 100, 0)
    assert tuple(img[at((1.0, 0.1))]) == (50, 50, 50)
    assert tuple(img[at((1.9, 0.85))]) == (0, 200, 200)
    assert tuple(img[at((0.3, 0.9))]) == WHITE  # and nothing elsewhere


def test_per_item_colours_and_skipped_items() -> None:
    canvas = Canvas(200, 100, (0.0, 0.0), (2.0, 1.0), background=WHITE)
    points = np.array([[0.5, 0.5], [np.nan, 0.5], [1e12, 0.5], [1.5, 0.5]])
    canvas.discs(points, 3, [RED, RED, RED, (0, 0, 255)])  # the NaN and the far one are skipped
    canvas.segments(points[:2], points[2:], RED)  # both segments have an unusable end
    img = canvas.to_array()
    assert tuple(img[canvas.to_px.pixel((0.5, 0.5))]) == RED
    assert tuple(img[canvas.to_px.pixel((1.5, 0.5))]) == (0, 0, 255)
    assert (img[:100] != WHITE).any(axis=2).sum() < 2 * 40  # two small discs, no lines


def test_bad_drawing_input_is_named() -> None:
    canvas = Canvas(20, 10, (0.0, 0.0), (2.0, 1.0))
    with pytest.raises(ValueError, match="colour"):
        canvas.discs(np.zeros((3, 2)), 2, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="polygon vertices"):
        canvas.polygons(np.zeros((3, 2, 2)), RED)
    with pytest.raises(ValueError, match="style"):
        canvas.crosses(np.zeros((1, 2)), 3, RED, style="o")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="marker"):
        LegendEntry("truth", "star")  # type: ignore[arg-type]


def test_identity_colors_deterministic_and_distinct() -> None:
    colors = identity_colors(np.arange(21))
    assert colors.shape == (21, 3) and colors.dtype == np.uint8
    assert np.array_equal(identity_colors([7, 3, 7])[[0, 2]], identity_colors([7, 7]))
    diff = np.abs(colors[:, None, :].astype(int) - colors[None, :, :].astype(int)).sum(axis=2)
    assert diff[~np.eye(21, dtype=bool)].min() >= 20


# ---------------------------------------------------------------------------- env frames


def test_belt_truth_detections_and_tracks_are_where_the_map_puts_them() -> None:
    env = gym.make("BeltSorter-v0", render_mode="rgb_array", noise_std=0.0, merge_touching=False)
    _, info = env.reset(seed=0)
    spec = env.unwrapped.sensor_spec
    truth = info["truth"]
    live = truth["ids"] >= 0
    positions = truth["positions"][live]
    # one track, away from the particles' centres, drawn as a ring of radius 7 px
    canvas = env.unwrapped._canvas()
    centre = [spec.region_high[0] / 2, spec.region_high[1] / 2]
    track_at = canvas.to_px.to_world(np.floor(canvas.to_px(centre)) + 0.5)  # a pixel's centre
    env.step(pack_report(np.array([5]), track_at[None], np.array([-1]), spec.max_tracks))
    scene, _, canvas = scene_of(env, env.render())
    detection = legend_color(env, "detection")
    assert detection == (0, 0, 0)
    # every particle's centre carries a detection cross (noise-free), in the legend's colour
    hits = [tuple(scene[canvas.to_px.pixel(p)]) == detection for p in positions]
    assert len(hits) > 20 and all(hits)
    row, col = canvas.to_px.pixel(track_at)
    ring = identity_colors([5])[0]
    assert all(tuple(scene[row, col + d]) == tuple(ring) for d in (-6, 6)), "the track's ring, radius 7 px"


def test_belt_particles_are_drawn_in_their_identity_colours() -> None:
    env = gym.make("BeltSorter-v0", render_mode="rgb_array", p_detect=0.0)
    _, info = env.reset(seed=1)
    truth = info["truth"]
    live = truth["ids"] >= 0
    scene, _, canvas = scene_of(env, env.render())
    colors = identity_colors(truth["ids"][live])
    got = np.array([scene[canvas.to_px.pixel(p)] for p in truth["positions"][live]])
    assert np.mean(np.all(got == colors, axis=1)) > 0.95  # touching particles may paint a centre


def test_single_target_truth_has_the_legend_colour() -> None:
    env = gym.make("SineTarget-v0", render_mode="rgb_array", p_detect=0.0, clutter_rate=0.0)
    _, info = env.reset(seed=0)
    scene, _, canvas = scene_of(env, env.render())
    pos = info["truth"]["positions"][0]
    assert tuple(scene[canvas.to_px.pixel(pos)]) == legend_color(env, "truth")


def test_keypoint_skeletons_of_truth_and_tracks() -> None:
    env = gym.make(
        "KeypointWalkers-v0",
        render_mode="rgb_array",
        num_people=1,
        initial_people=1,
        arrival_rate=0.0,
        vanish_rate=0.0,
        occlusion=False,
        num_occluders=0,
        p_detect=0.0,
        clutter_rate=0.0,
    )
    _, info = env.reset(seed=0)
    u = env.unwrapped
    t = info["truth"]
    person = int(np.flatnonzero(t["ids"] >= 0)[0])
    kp, vis = t["keypoints"][person], t["keypoint_visible"][person]
    height = u.params.height
    scene, _, canvas = scene_of(env, env.render())

    def pixel(xy_image: np.ndarray) -> tuple[int, int]:
        return canvas.to_px.pixel((xy_image[0], height - xy_image[1]))  # image y runs down

    color = tuple(identity_colors([t["ids"][person]])[0])
    assert vis.sum() >= 10
    assert all(tuple(scene[pixel(p)]) == color for p in kp[vis])
    report = pack_report(np.array([9]), kp[None] + [40.0, 0.0], np.array([-1]), u.sensor_spec.max_tracks)
    env.step(report)
    scene, _, canvas = scene_of(env, env.render())
    from track_envs.envs.skeleton import SKELETON_EDGES

    a, b = SKELETON_EDGES[0]
    mid = 0.5 * (kp[a] + kp[b]) + [40.0, 0.0]
    assert tuple(scene[pixel(mid)]) == tuple(identity_colors([9])[0])


def test_empty_scene_renders_the_background_and_footer(tmp_path) -> None:
    path = tmp_path / "empty.csv"
    tracks = np.full((5, 2, 2), np.nan)
    tracks[4] = [[0.0, 0.0], [1.0, 0.5]]  # frames 0-3 are empty
    write_track_csv(path, tracks)
    env = gym.make("BeltReplay-v0", path=str(path), render_mode="rgb_array", max_detections=8, max_tracks=8)
    env.reset(seed=0)
    env.step(empty_report(8, (2,)))
    scene, footer, _ = scene_of(env, env.render())
    assert len(np.unique(scene.reshape(-1, 3), axis=0)) == 1  # no particle, no detection, no track
    assert len(np.unique(footer.reshape(-1, 3), axis=0)) > 3


@pytest.mark.parametrize("env_id", track_envs.ENV_IDS)
def test_footer_shows_the_legend_and_the_frame_number(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, env.unwrapped.position_shape)
    env.step(report)
    _, first, canvas = scene_of(env, env.render())  # frame 0 and the report on it
    env.step(report)
    _, second, _ = scene_of(env, env.render())  # frame 1
    w = canvas.width
    caption, legend = slice(0, w // 5), slice(w // 3, w)
    # the caption (left) changes with the frame; the legend (right) stays, in its colours
    assert (first[:, caption] != second[:, caption]).any()
    assert np.array_equal(first[:, legend], second[:, legend])
    colours = {tuple(c) for c in second[:, legend].reshape(-1, 3).tolist()}
    for entry in env.unwrapped._legend():
        wanted = [entry.color] if entry.color is not None else identity_colors([1, 2, 3]).tolist()
        assert all(tuple(c) in colours for c in wanted), entry
    dark = np.all(second < 80, axis=2)
    assert dark[:, caption].sum() > 30 and dark[:, legend].sum() > 100  # text


# ---------------------------------------------------------------------------- human mode


def test_human_mode_shows_frames_in_a_headless_window(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    env = gym.make("BeltSorter-v0", render_mode="human")
    env.reset(seed=0)
    env.step(empty_report(env.unwrapped.sensor_spec.max_tracks, (2,)))
    window = env.unwrapped._window
    assert window.is_open and env.render() is None
    import pygame

    shown = pygame.surfarray.array3d(pygame.display.get_surface()).transpose(1, 0, 2)
    reference = gym.make("BeltSorter-v0", render_mode="rgb_array")
    reference.reset(seed=0)
    reference.step(empty_report(reference.unwrapped.sensor_spec.max_tracks, (2,)))
    assert np.array_equal(shown, reference.render())  # the window shows the rgb_array frame
    env.close()
    assert not window.is_open
    env.close()


def test_human_window_without_pygame_names_the_install(monkeypatch: pytest.MonkeyPatch) -> None:
    import builtins

    from gymnasium.error import DependencyNotInstalled

    from track_envs.envs.render_window import HumanWindow

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


def test_rgb_array_rendering_does_not_import_pygame() -> None:
    code = (
        "import sys, gymnasium as gym, track_envs\n"
        "env = gym.make('BeltSorter-v0', render_mode='rgb_array'); env.reset(seed=0); env.render()\n"
        "assert 'pygame' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
