"""SineTarget-v0 and PiecewiseTarget-v0: one target, missed detections and occlusion (Jung et al. 2019).

Both scenes follow Jung, Schlangen and Charlish, "Sequential Monte Carlo Filtering with Long
Short-Term Memory Prediction" (FUSION 2019), Sec. IV: one target moves with step ``Δ`` (0.2) per
frame; a point sensor sees it with probability ``p_d`` and Gaussian noise ``σ_m`` (given in
multiples of ``Δ``, as in the paper), and an occlusion interval suppresses every detection.

The scene is simulated in a *local* frame (the paper's unrotated curve starting at the origin) and
mapped to the world by a rotation about the origin and a shift
([`to_world`][track_envs.envs.single_target.to_world]). Detections are drawn in the local frame
([`draw_detections`][track_envs.envs.single_target.draw_detections], the one measurement model every user of
these scenes shares, including ``examples/pf_paper_figures.py``) and mapped with the same transform, so a
rotated scene is exactly the rotation of the unrotated one under the same seed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from track_envs.envs.base import TrackingEnv, Truth
from track_envs.envs.drift import SensorDrift
from track_envs.envs.sensors import CLUTTER_ID
from track_envs.infra.arguments import (
    check_int,
    check_non_negative,
    check_number,
    check_positive,
    check_probability,
    check_vector,
)
from track_envs.values.types import SensorSpec

#: Step length ``Δ`` of Jung et al. (2019) (x-advance per frame of the sine curve).
STEP = 0.2
#: A track is lost when its mean estimation error exceeds this (Jung et al. 2019, Sec. IV-B4), in
#: trajectory units.
LOST_THRESHOLD = 5.0


def n_frames_for(periods: float, step: float = STEP) -> int:
    """Frames of a scene of ``periods`` sine periods: ``t = 0 … ⌊periods·2π/Δ⌋`` (786 for 25)."""
    return int(np.floor(periods * 2 * np.pi / step)) + 1


def sine_trajectory(n_frames: int, step: float = STEP) -> NDArray[np.float64]:
    """The local sine curve of Jung et al. (2019), Eq. (5): ``x_t = (t·Δ, sin(t·Δ))``, shape (n_frames, 2)."""
    t = np.arange(n_frames, dtype=np.float64)
    return np.stack([t * step, np.sin(t * step)], axis=1)


def piecewise_trajectory(
    n_frames: int,
    rng: np.random.Generator,
    step: float = STEP,
    segment_steps: tuple[int, int] = (10, 50),
    max_heading_deg: float = 60.0,
) -> NDArray[np.float64]:
    """A local piecewise-linear trajectory (Jung et al. 2019, Fig. 8) from the origin, shape (n_frames, 2).

    Segments have a heading uniform in ``[-max_heading_deg, max_heading_deg]`` from the x-axis and
    a length uniform in ``segment_steps`` (inclusive) steps; every step has length ``Δ``.
    """
    lo, hi = segment_steps
    headings: list[NDArray[np.float64]] = []
    total = 0
    while total < n_frames - 1:
        length = int(rng.integers(lo, hi + 1))
        heading = np.deg2rad(rng.uniform(-max_heading_deg, max_heading_deg))
        headings.append(np.full(length, heading))
        total += length
    theta = np.concatenate([np.zeros(0), *headings])[: n_frames - 1]
    moves = step * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    return np.concatenate([np.zeros((1, 2)), np.cumsum(moves, axis=0)])


def to_world(points: ArrayLike, rotation_deg: float, offset: ArrayLike) -> NDArray[np.float64]:
    """Rotate ``points`` (..., 2) by ``rotation_deg`` about the origin, then shift by ``offset`` (2,).

    ``x' = c·x − s·y + o_x``, ``y' = s·x + c·y + o_y`` with ``c, s = cos, sin(rotation)``.
    """
    p = np.asarray(points, dtype=np.float64)
    o = np.asarray(offset, dtype=np.float64)
    a = np.deg2rad(rotation_deg)
    c, s = np.cos(a), np.sin(a)
    x, y = p[..., 0], p[..., 1]
    return np.stack([c * x - s * y + o[0], s * x + c * y + o[1]], axis=-1)


def draw_detections(
    positions: ArrayLike,
    rng: np.random.Generator,
    *,
    noise_std: float | ArrayLike,
    p_detect: float | ArrayLike,
    occluded: bool | ArrayLike = False,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """One frame of target detections of ``n`` independent single-target scenes.

    ``detected_i ~ Bernoulli(p_detect_i)`` (never while ``occluded_i``) and
    ``z_i = x_i + noise_std_i · ε_i``, ``ε_i ~ N(0, I_2)``; the draws are one ``rng.random(n)`` then
    one ``rng.standard_normal((n, 2))``, always, so the stream does not depend on the parameters.

    Args:
        positions: True positions (n, 2).
        rng: The generator every draw comes from.
        noise_std: Noise standard deviation per axis, scalar or (n,).
        p_detect: Detection probability, scalar or (n,).
        occluded: Whether each scene is occluded this frame, scalar or (n,).

    Returns:
        ``(z, detected)``: measurements (n, 2) (drawn for every row) and the detection flags (n,).
    """
    x = np.asarray(positions, dtype=np.float64)
    n = len(x)
    detected = (rng.random(n) < np.asarray(p_detect)) & ~np.asarray(occluded, dtype=bool)
    z = x + rng.standard_normal((n, 2)) * np.asarray(noise_std, dtype=np.float64)[..., None]
    return z, detected


class SingleTargetEnv(TrackingEnv):
    """The shared single-target scene; subclasses give the local trajectory
    (`_trajectory`).

    See [`SineTargetEnv`][track_envs.envs.SineTargetEnv] for the contract (observation, reward, arguments).
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 30}  # noqa: RUF012

    def __init__(
        self,
        *,
        periods: float = 25.0,
        step: float = STEP,
        rotation_deg: float = 0.0,
        offset: tuple[float, float] = (0.0, 0.0),
        sigma_m: float = 0.5,
        noise_std: float | None = None,
        p_detect: float = 0.9,
        occlusion_start: int = 100,
        occlusion_length: int = 0,
        clutter_rate: float = 0.0,
        clutter_half_width: float = 2.0,
        drift: SensorDrift | Mapping[str, Any] | str | None = None,
        max_detections: int | None = None,
        max_tracks: int = 4,
        gospa_c: float = LOST_THRESHOLD,
        render_mode: str | None = None,
    ):
        self.periods = check_positive("periods", periods)
        self.step_length = check_positive("step", step)
        self.n_frames = n_frames_for(self.periods, self.step_length)
        if self.n_frames < 2:
            raise ValueError(f"periods={periods!r} gives fewer than 2 frames; use periods > step / (2π)")
        self.rotation_deg = check_number("rotation_deg", rotation_deg)
        off = check_vector("offset", offset, 2)
        self.offset = (float(off[0]), float(off[1]))
        self.sigma_m = check_non_negative("sigma_m", sigma_m)
        std = self.sigma_m * self.step_length if noise_std is None else noise_std
        std = check_non_negative("noise_std", std)
        start = check_int("occlusion_start", occlusion_start, 0)
        self.occlusion = (start, start + check_int("occlusion_length", occlusion_length, 0))
        clutter_rate = check_non_negative("clutter_rate", clutter_rate)
        self._set_drift(drift)
        most_clutter = self.drift.highest("clutter_rate", clutter_rate) if self.drift else clutter_rate
        self.clutter_half_width = check_positive("clutter_half_width", clutter_half_width)
        self.gospa_c = check_positive("gospa_c", gospa_c)
        room = 1 + int(np.ceil(most_clutter + 6 * np.sqrt(most_clutter)))
        max_detections = max(8, room) if max_detections is None else max_detections
        max_detections = check_int("max_detections", max_detections, 1)
        max_tracks = check_int("max_tracks", max_tracks, 1)
        low, high = self._world_box(self.clutter_half_width + 1.0)
        spec = SensorSpec(
            dt=1.0,
            dim=2,
            noise_std=std,
            p_detect=check_probability("p_detect", p_detect),
            clutter_rate=clutter_rate,
            region_low=(float(low[0]), float(low[1])),
            region_high=(float(high[0]), float(high[1])),
            max_detections=int(max_detections),
            max_tracks=int(max_tracks),
            units="trajectory units",
        )
        margin = 10 * (self.drift.highest("noise_std", std) if self.drift else std) + 1.0
        self._setup_spaces(
            spec, max_targets=1, obs_low=low - margin, obs_high=high + margin, render_mode=render_mode
        )
        self._local = np.zeros((0, 2))
        self._world = np.zeros((0, 2))
        self._index = 0

    # -- the scene ----------------------------------------------------------------------------
    def _local_box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """A box (low, high) that holds every local trajectory of this env."""
        raise NotImplementedError

    def _trajectory(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """The local trajectory of one episode, (n_frames, 2)."""
        raise NotImplementedError

    def _world_box(self, pad: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo, hi = self._local_box()
        corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        world = to_world(corners, self.rotation_deg, self.offset)
        return world.min(axis=0) - pad, world.max(axis=0) + pad

    @property
    def trajectory(self) -> NDArray[np.float64]:
        """The true world trajectory of the current episode, (n_frames, 2) (after ``reset``)."""
        return self._world

    def occluded(self, frame: int) -> bool:
        """Whether ``frame`` lies in the occlusion interval ``[start, start + length)``."""
        return self.occlusion[0] <= frame < self.occlusion[1]

    def _reset_scene(self) -> None:
        self._local = self._trajectory(self.np_random)
        self._world = to_world(self._local, self.rotation_deg, self.offset)
        self._index = 0

    def _advance(self) -> bool:
        self._index += 1
        return self._index >= self.n_frames

    def _truth(self) -> Truth:
        return Truth(
            ids=np.zeros(1, dtype=np.int64),
            positions=self._world[self._index : self._index + 1].copy(),
            visible=np.ones(1, dtype=bool),
        )

    def _sense(self, truth: Truth) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The target's detection ([`draw_detections`][track_envs.envs.single_target.draw_detections]) and
        clutter, drawn locally, then mapped.

        Clutter: ``K ~ Poisson(clutter_rate)`` points uniform over the square of half-width
        ``clutter_half_width`` centred on the target's true position. During the occlusion the
        sensor reports nothing at all, clutter included (the draws are still made, so the random
        stream does not depend on the occlusion).
        """
        now = self._sensor_now()  # the spec's values, or the drift's (track_envs.envs.drift)
        rng = self.np_random
        here = self._local[self._index : self._index + 1]
        z, detected = draw_detections(
            here, rng, noise_std=now.noise_std, p_detect=now.p_detect, occluded=self.occluded(self._index)
        )
        z = z[detected]
        source = np.zeros(len(z), dtype=np.int64)
        k = int(rng.poisson(now.clutter_rate)) if now.clutter_rate > 0 else 0
        if k:
            w = self.clutter_half_width
            clutter = here + rng.uniform(-w, w, size=(k, 2))
            if self.occluded(self._index):
                clutter = clutter[:0]
            z = np.concatenate([z, clutter])
            source = np.concatenate([source, np.full(len(clutter), CLUTTER_ID, dtype=np.int64)])
        return to_world(z, self.rotation_deg, self.offset), source

    def default_metrics(self) -> list[Any]:
        """[`SingleTargetError`][track_envs.metrics.SingleTargetError] with this env's occlusion, and
        HOTA ([`Hota`][track_envs.metrics.Hota]) with τ the distance at which a track
        counts as lost (5 trajectory units, Jung et al. 2019)."""
        from track_envs.metrics.hota_stream import Hota
        from track_envs.metrics.single_target import LOST_THRESHOLD, SingleTargetError

        return [SingleTargetError(occlusion=self.occlusion), Hota(threshold=LOST_THRESHOLD)]

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        """A 16 × 10 window (trajectory units) centred on the target of the frame drawn."""
        from track_envs.envs.rendering import Canvas

        frame = self._render_frame
        snapshot = frame[0] if frame is not None else None
        centre = snapshot.positions[0] if snapshot is not None and len(snapshot.positions) else self._world[0]
        half = np.array([8.0, 5.0])
        return Canvas(800, 500, tuple(centre - half), tuple(centre + half), (245, 245, 240))

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        path = self._world
        # the path shaded by time (dark blue early, light late), the occlusion interval in orange
        shade = np.linspace(0.0, 1.0, max(len(path) - 1, 1))[:, None]
        colors = np.round((1 - shade) * [40, 70, 170] + shade * [170, 200, 240]).astype(np.uint8)
        start, stop = self.occlusion
        colors[start : max(start, stop - 1)] = (235, 140, 40)
        canvas.segments(path[:-1], path[1:], colors, thickness_px=2)
        if snapshot is not None and len(snapshot.positions):
            canvas.discs(snapshot.positions, 6, (30, 120, 40))

    def _legend(self) -> list[Any]:
        from track_envs.envs.rendering import LegendEntry

        return [
            LegendEntry("truth", "disc", (30, 120, 40)),
            LegendEntry("path", "line", (40, 70, 170)),
            LegendEntry("occluded", "line", (235, 140, 40)),
            LegendEntry("detection", "cross", (0, 0, 0)),
            LegendEntry("track", "ring"),
        ]


class SineTargetEnv(SingleTargetEnv):
    """One target on the sine curve of Jung et al. (2019), seen by a point sensor with misses and occlusion.

    ## Description
    The target follows ``x_t = (t·Δ, sin(t·Δ))`` (Jung et al. 2019, Eq. (5)), ``Δ = step = 0.2``, for
    ``periods`` (25) periods, ``t = 0 … 785``; the curve is rotated by ``rotation_deg`` about the
    origin and then shifted by ``offset``. The truth is noise-free. Each frame the sensor detects the
    target with probability ``p_detect`` (never inside the occlusion interval
    ``[occlusion_start, occlusion_start + occlusion_length)``) at its true position plus Gaussian
    noise of standard deviation ``sigma_m·Δ`` per axis, and adds ``Poisson(clutter_rate)`` clutter
    points uniform over a square of half-width ``clutter_half_width`` around the target. Positions
    are in trajectory units (``sensor_spec.units``); one frame is one time step (``dt = 1``).

    ## Observation
    ``Dict(detections=Box(max_detections, 2) float32, mask=Box(max_detections,) int8)``, rows
    shuffled, padding zero. ``info["detection_ids"]`` is 0 for the target's detection, -1 for clutter.

    ## Action
    The tracker's report (see `track_envs.contracts.report`); a single-target
    tracker reports one row.

    ## Reward
    ``−GOSPA`` (cut-off ``gospa_c``, p = 2, α = 2) of the report against the target, which counts as
    visible throughout (the occlusion hides it from the sensor only: Jung et al. (2019) score the estimate
    through the occlusion).

    ## Starting State
    The target at ``to_world((0, 0))`` = ``offset``; frame 0 is sensed like any other.

    ## Episode End
    Terminates after the last frame of the curve (786 frames for 25 periods). No truncation.

    ## Arguments
    - ``periods``: sine periods of the curve (default 25).
    - ``step``: ``Δ``, x-advance per frame (default 0.2).
    - ``rotation_deg``, ``offset``: rotation about the origin (degrees), then shift (default none).
    - ``sigma_m``: measurement noise in multiples of ``Δ`` (default 0.5, i.e. 0.1 units).
    - ``noise_std``: measurement noise in trajectory units; overrides ``sigma_m`` when given (the
      name every point env shares).
    - ``p_detect``: detection probability outside the occlusion (default 0.9).
    - ``occlusion_start``, ``occlusion_length``: the occlusion interval in frames (default 100, 0).
    - ``clutter_rate``: mean clutter points per frame (default 0); ``clutter_half_width`` (default 2).
    - ``drift``: the sensor's drift over an episode (`track_envs.envs.drift`): noise
    std, detection
      probability and clutter rate on a schedule, ``sensor_spec`` nominal, the true values in
      ``info["sensor"]``; default None.
    - ``max_detections`` (default ``max(8, 1 + clutter room)``, room for the drift's highest
      clutter rate), ``max_tracks`` (default 4).
    - ``gospa_c``: GOSPA cut-off of the reward (default 5, the paper's track-loss threshold).
    - ``render_mode``: ``"rgb_array"`` or ``"human"`` (a 16 × 10 window following the target).

    ## Version History
    - v0: the first version; its streams are those it had when added
      (2026-11-22), pinned since 2026-12-02. Added without changing them: ``drift`` (default
      None).
    """

    def _local_box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return np.array([0.0, -1.0]), np.array([(self.n_frames - 1) * self.step_length, 1.0])

    def _trajectory(self, rng: np.random.Generator) -> NDArray[np.float64]:
        return sine_trajectory(self.n_frames, self.step_length)


class PiecewiseTargetEnv(SingleTargetEnv):
    """One target on a random piecewise-linear trajectory (Jung et al. 2019, Fig. 8), same sensor.

    ## Description
    As [`SineTargetEnv`][track_envs.envs.SineTargetEnv], but the local trajectory starts at the origin and is
    made of straight segments, each with a heading uniform in ``[-max_heading_deg, max_heading_deg]`` from the
    x-axis and a length uniform in ``segment_steps`` steps, every step of length ``Δ``; the segments are
    drawn from the env's RNG at ``reset``. Same number of frames as the sine scene of ``periods``.

    ## Observation
    As SineTarget-v0.

    ## Action
    As SineTarget-v0.

    ## Reward
    As SineTarget-v0.

    ## Starting State
    The target at ``offset``; the segments are new every ``reset``.

    ## Episode End
    Terminates after ``⌊periods·2π/Δ⌋ + 1`` frames (786 by default).

    ## Arguments
    Those of SineTarget-v0, and
    - ``segment_steps``: ``(min, max)`` steps per segment, inclusive (default (10, 50)).
    - ``max_heading_deg``: largest heading from the x-axis (default 60, below 90).

    ## Version History
    - v0: the first version; its streams are those it had when added
      (2026-11-22), pinned since 2026-12-02. Added without changing them: ``drift`` (default
      None).
    """

    def __init__(
        self,
        *,
        segment_steps: tuple[int, int] = (10, 50),
        max_heading_deg: float = 60.0,
        **kwargs: Any,
    ):
        steps = segment_steps if isinstance(segment_steps, tuple | list) and len(segment_steps) == 2 else ()
        if len(steps) != 2:
            raise ValueError(f"segment_steps must be integers (min, max), got {segment_steps!r}")
        lo = check_int("segment_steps[0]", steps[0], 1)
        hi = check_int("segment_steps[1]", steps[1], lo)
        heading = check_number("max_heading_deg", max_heading_deg)
        if not 0.0 <= heading < 90.0:
            raise ValueError(f"max_heading_deg must be in [0, 90), got {max_heading_deg!r}")
        self.segment_steps = (lo, hi)
        self.max_heading_deg = heading
        super().__init__(**kwargs)

    def _local_box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        length = (self.n_frames - 1) * self.step_length
        spread = length * np.sin(np.deg2rad(self.max_heading_deg))
        return np.array([0.0, -spread]), np.array([length, spread])

    def _trajectory(self, rng: np.random.Generator) -> NDArray[np.float64]:
        return piecewise_trajectory(
            self.n_frames, rng, self.step_length, self.segment_steps, self.max_heading_deg
        )
