"""BeltSorter-v0: an optical belt sorter seen from above by a 100 Hz camera."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.envs.base import TrackingEnv, Truth
from track_envs.envs.belt_kernels import padded_state
from track_envs.envs.belt_physics import BeltParams, BeltWorld, resolve_mixture
from track_envs.sensors import check_non_negative, check_positive, check_probability
from track_envs.types import SensorSpec

_BELT_GREY = (150, 150, 150)
_WALL = (60, 60, 60)
_WINDOW = (40, 90, 200)


class BeltSorterEnv(TrackingEnv):
    """Optical belt sorting: many bulk particles on a conveyor belt, their centroids seen by a camera.

    ## Description
    A top-down 2-D pymunk simulation of the conveyor belt of an optical belt sorter (paper 000,
    Pollithy et al., Fig. 2). Particles land on the belt upstream of the camera window with the
    speed of the feeding chute, are accelerated toward belt speed by Coulomb belt friction,
    collide with each other and with the side walls (out-of-model motion, paper 000 Fig. 1), and
    leave past the belt end. A camera sees a window of the belt at 100 Hz and reports centroids.
    Units are metres and seconds. The defaults reproduce the authors' DEM statistics of their belt:
    median along-belt speed rising from ≈1.0–1.12 m/s at the window entry to ≈1.44 m/s at its exit,
    median acceleration ≈1.57 m/s², 98% of lateral speeds below 0.07–0.09 m/s, each particle seen for
    ≈31–33 frames, ≈2 new particles per frame, ≈60 visible on average with bursts of 140–210.

    ## Observation
    ``Dict(detections=Box(max_detections, 2) float32, mask=Box(max_detections,) int8)``: measured
    centroids ``(x, y)`` in metres (x along the belt, y across), zero-padded; rows are shuffled
    every frame. Detections are ``x + N(0, noise_std²)`` for each particle in the window with
    probability ``p_detect``, plus ``Poisson(clutter_rate)`` clutter points uniform in the window.

    ## Action
    The tracker's report (see :mod:`track_envs.report`): ``ids``, ``positions`` (max_tracks, 2),
    ``detection``, ``mask``.

    ## Reward
    ``−GOSPA`` (cut-off ``gospa_c`` metres, p = 2, α = 2) between the reported positions and the
    true centroids of the particles in the window at the frame the report answers.

    ## Starting State
    The belt has run for ``physics.warmup_time`` seconds, so the first frame is in steady state.

    ## Episode End
    The belt never stops: no termination. ``gym.make`` truncates at 1,500 frames (15 s).

    ## Info
    ``t``, ``frame``, ``truth`` (``ids``, ``positions``, ``visible``, ``velocities`` (m/s),
    ``angles`` (rad), ``kinds`` (index into ``kind_names``)), ``detection_ids``,
    ``dropped_detections``, ``dropped_targets``.

    ## Arguments
    - ``particle_kind``: ``"sphere"``, ``"cylinder"`` (default, the paper's DEM dataset),
      ``"cuboid"``, ``"mixture"`` or a mapping of kinds to weights.
    - ``noise_std``: measurement noise std in metres (default 1e-4; paper 000 sweeps 0–5e-4).
    - ``p_detect``: detection probability (default 1.0).
    - ``clutter_rate``: mean clutter detections per frame (default 0.0).
    - ``max_detections``: detection rows (default 256); ``max_tracks``: report rows (default 256);
      ``max_targets``: truth rows in ``info`` (default 256).
    - ``feed_rate``: particles per second (default 195); ``belt_speed``: m/s (default 1.44).
    - ``physics``: a :class:`~track_envs.envs.belt_physics.BeltParams` for everything else.
    - ``gospa_c``: GOSPA cut-off in metres (default 0.005).
    - ``render_mode``: ``"rgb_array"`` or ``"human"``.

    ## Version History
    - v0: first release.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 100}  # noqa: RUF012

    def __init__(
        self,
        *,
        particle_kind: str | Mapping[str, float] = "cylinder",
        noise_std: float = 1e-4,
        p_detect: float = 1.0,
        clutter_rate: float = 0.0,
        max_detections: int = 256,
        max_tracks: int = 256,
        max_targets: int = 256,
        feed_rate: float | None = None,
        belt_speed: float | None = None,
        physics: BeltParams | None = None,
        gospa_c: float = 0.005,
        render_mode: str | None = None,
    ):
        params = physics if physics is not None else BeltParams()
        if not isinstance(params, BeltParams):
            raise ValueError(f"physics must be a BeltParams, got {type(params).__name__}")
        self.physics = replace(
            params,
            feed_rate=params.feed_rate if feed_rate is None else feed_rate,
            belt_speed=params.belt_speed if belt_speed is None else belt_speed,
        )
        self.kinds = resolve_mixture(particle_kind)
        self.kind_names = list(self.kinds)
        for name, value in (("max_detections", max_detections), ("max_tracks", max_tracks)):
            if not (isinstance(value, int | np.integer) and value >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        self.gospa_c = check_positive("gospa_c", gospa_c)
        dt = 0.01
        p = self.physics
        spec = SensorSpec(
            dt=dt,
            dim=2,
            noise_std=check_non_negative("noise_std", noise_std),
            p_detect=check_probability("p_detect", p_detect),
            clutter_rate=check_non_negative("clutter_rate", clutter_rate),
            region_low=(0.0, 0.0),
            region_high=(p.window_length, p.window_width),
            max_detections=int(max_detections),
            max_tracks=int(max_tracks),
            units="m",
        )
        margin = 10 * spec.noise_std + 0.01
        self._setup_spaces(
            spec,
            max_targets=max_targets,
            obs_low=np.array(spec.region_low) - margin,
            obs_high=np.array(spec.region_high) + margin,
            truth_extra_shapes={"velocities": (2,), "angles": (), "kinds": ()},
            render_mode=render_mode,
        )
        self.world: BeltWorld | None = None

    # -- simulation ---------------------------------------------------------------------------
    def _reset_scene(self) -> None:
        self.world = BeltWorld(self.physics, self.kinds, self.np_random, self.sensor_spec.dt)
        self.world.warm_up()

    def _advance(self) -> bool:
        assert self.world is not None
        self.world.step()
        return False

    def _truth(self) -> Truth:
        assert self.world is not None
        s = self.world.state((0.0, self.physics.window_length))
        return Truth.all_in_view(
            s.ids, s.position, {"velocities": s.velocity, "angles": s.angle, "kinds": s.kind}
        )

    def _padded_truth(self, truth: Truth, m: int) -> dict[str, NDArray]:
        """The base class's padding in one compiled call (every particle in the window is visible)."""
        e = truth.extra
        ids, positions, visible, velocities, angles, kinds = padded_state(
            truth.ids, truth.positions, e["velocities"], e["angles"], e["kinds"], m, self.max_targets
        )
        return {
            "ids": ids,
            "positions": positions,
            "visible": visible,
            "velocities": velocities,
            "angles": angles,
            "kinds": kinds,
        }

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        from track_envs.rendering import Canvas

        p = self.physics
        low = (p.drop_x - p.drop_spread - 0.02, -0.02)
        high = (p.window_length + p.exit_margin + 0.02, p.window_width + 0.02)
        scale = 1400.0
        return Canvas(
            round((high[0] - low[0]) * scale), round((high[1] - low[1]) * scale), low, high, (235, 235, 235)
        )

    def _snapshot(self) -> Any:
        return self.world.state() if self.world is not None else None

    def _legend(self) -> list[Any]:
        from track_envs.envs.belt_physics import PARTICLE_KINDS
        from track_envs.rendering import LegendEntry

        boxes = any(PARTICLE_KINDS[name].shape != "circle" for name in self.kind_names)
        return [
            LegendEntry("particle (truth)", "box" if boxes else "disc"),
            LegendEntry("detection", "cross", (0, 0, 0)),
            LegendEntry("track", "ring"),
            LegendEntry("camera window", "line", _WINDOW),
        ]

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        from track_envs.rendering import identity_colors

        p = self.physics
        x0 = p.drop_x - p.drop_spread - 0.05
        x1 = p.window_length + p.exit_margin
        canvas.fill_rect((x0, 0.0), (x1, p.window_width), _BELT_GREY)
        canvas.fill_rect((x0, -0.02), (x1 + 0.05, 0.0), _WALL)
        canvas.fill_rect((x0, p.window_width), (x1 + 0.05, p.window_width + 0.02), _WALL)
        corners = np.array(
            [[0, 0], [p.window_length, 0], [p.window_length, p.window_width], [0, p.window_width]]
        )
        canvas.segments(corners, np.roll(corners, -1, axis=0), _WINDOW, thickness_px=2)
        if self.world is None or snapshot is None:
            return
        s = snapshot
        colors = identity_colors(s.ids)
        kinds = self.world.kinds if self.world is not None else []
        for k, kind in enumerate(kinds):
            rows = s.kind == k
            if not rows.any():
                continue
            if kind.shape == "circle":
                canvas.discs(s.position[rows], 0.5 * kind.length * canvas.to_px.scale[0], colors[rows])
            else:
                canvas.polygons(
                    _box_corners(s.position[rows], s.angle[rows], kind.length, kind.width), colors[rows]
                )


def _box_corners(centers: NDArray, angles: NDArray, length: float, width: float) -> NDArray:
    """Corners (n, 4, 2) of rectangles of size length × width rotated by ``angles``."""
    local = 0.5 * np.array([[length, width], [-length, width], [-length, -width], [length, -width]])
    c, s = np.cos(angles), np.sin(angles)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (n, 2, 2)
    return centers[:, None, :] + np.einsum("nij,kj->nki", rot, local)
