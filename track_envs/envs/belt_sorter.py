"""BeltSorter-v0: an optical belt sorter seen from above by a 100 Hz camera."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.envs.base import TrackingEnv, Truth
from track_envs.envs.belt_kernels import padded_state
from track_envs.envs.belt_physics import (
    BELT_PRESETS,
    BOX_ROUNDING,
    PARTICLE_KINDS,
    BeltParams,
    BeltWorld,
    belt_preset,
    resolve_mixture,
    scene_rows,
)
from track_envs.envs.blobs import (
    MAX_MERGE_TOLERANCE,
    MAX_MERGED,
    MERGE_TOLERANCE,
    merge_blobs,
    merged_rows,
    silhouette_table,
)
from track_envs.envs.drift import SensorDrift
from track_envs.envs.nozzle import (
    DEFAULT_NOZZLE_OFFSET,
    check_nozzle_offset,
    pack_crossings,
    warn_dropped_crossings,
)
from track_envs.infra.arguments import check_int, check_non_negative, check_positive, check_probability
from track_envs.values.types import SensorSpec

_BELT_GREY = (150, 150, 150)
_WALL = (60, 60, 60)
_WINDOW = (40, 90, 200)


class BeltSorterEnv(TrackingEnv):
    """Optical belt sorting: many bulk particles on a conveyor belt, their centroids seen by a camera.

    ## Description
    A top-down 2-D pymunk simulation of the conveyor belt of an optical belt sorter (Pollithy et al. 2020,
    Pollithy et al., Fig. 2). Particles land on the belt upstream of the camera window with the
    speed of the feeding chute, are accelerated toward belt speed by Coulomb belt friction,
    collide with each other and with the side walls (out-of-model motion, Pollithy et al. 2020, Fig. 1), and
    leave past the belt end. A camera sees a window of the belt at 100 Hz and reports centroids.
    Units are metres and seconds. The defaults reproduce the authors' DEM statistics of their belt:
    median along-belt speed rising from ≈1.0–1.12 m/s at the window entry to ≈1.44 m/s at its exit,
    median acceleration ≈1.57 m/s², 98% of lateral speeds below 0.07–0.09 m/s, each particle seen for
    ≈31–33 frames, ≈2 new particles per frame, ≈60 visible on average with bursts of 140–210.

    ## Observation
    ``Dict(detections=Box(max_detections, 2) float32, mask=Box(max_detections,) int8)``: measured
    centroids ``(x, y)`` in metres (x along the belt, y across), zero-padded; rows are shuffled
    every frame. Detections are ``x + N(0, noise_std²)`` for each blob in the window with
    probability ``p_detect``, plus ``Poisson(clutter_rate)`` clutter points uniform in the window.
    A blob is a particle, or, with ``merge_touching`` (the default), a group of particles whose
    silhouettes touch, seen as one region by the camera: its ``x`` is the area-weighted centroid
    of the group (see `track_envs.envs.blobs` for the silhouettes and the touching
    test).

    ## Action
    The tracker's report (see `track_envs.contracts.report`): ``ids``,
    ``positions`` (max_tracks, 2), ``detection``, ``mask``.

    ## Reward
    ``−GOSPA`` (cut-off ``gospa_c`` metres, p = 2, α = 2) between the reported positions and the
    true centroids of the particles in the window at the frame the report answers.

    ## Starting State
    The belt has run for ``physics.warmup_time`` seconds, so the first frame is in steady state.

    ## Episode End
    The belt never stops: no termination. ``gym.make`` truncates at 1,500 frames (15 s).

    ## Info
    ``t``, ``frame``, ``truth`` (``ids``, ``positions``, ``visible``, ``velocities`` (m/s),
    ``angles`` (rad), ``kinds`` (index into ``kind_names``), and the nozzle bar's
    ``nozzle_ids``, ``nozzle_times``, ``nozzle_lateral``), ``detection_ids``,
    ``dropped_detections``, ``dropped_targets``, and for merged blobs:

    - ``detection_ids``: for a merged detection, the id of its largest-area particle (ties: the
      lowest id).
    - ``detection_ids_merged``: (max_detections, 8) int64, every truth id behind each detection
      row, largest area first, −1 padded; column 0 equals ``detection_ids``, columns 1–7 are −1
      except on merged detections. A blob of more than 8 particles lists its 8 largest.
    - ``truncated_merge_ids``: member ids left out of ``detection_ids_merged`` so far this episode.

    The nozzle bar (`track_envs.envs.nozzle`): a line across the belt at
    ``x = L = window_length + nozzle_offset``. Particles stay on the simulated belt until they
    are past it, and each frame's ``truth`` lists the particles that crossed it since the previous
    frame: ``nozzle_ids`` (max_targets,) int64, −1 padded; ``nozzle_times``, the crossing time in
    seconds on the clock of ``t``, interpolated within the physics substep in which the centroid
    reached ``L`` (exact: within a substep a body moves on a straight line); ``nozzle_lateral``,
    its ``y`` there. ``sensor_spec.sorting_line`` is ``L``, so a tracker can predict the crossing
    (the report's optional sorting channel, `track_envs.contracts.report`),
    scored by [`SortingPrediction`][track_envs.metrics.SortingPrediction] (``sorting_*`` metrics).

    ## Arguments
    - ``particle_kind``: ``"sphere"``, ``"cylinder"`` (default, the paper's DEM dataset),
      ``"cuboid"``, ``"mixture"`` or a mapping of kinds to weights.
    - ``noise_std``: measurement noise std in metres added to each centroid (default 1e-4;
      Pollithy et al. (2020) sweep 0–5e-4).
    - ``measurement_noise_std``: the noise std the sensor spec declares to a tracker
      (``sensor_spec.noise_std``); default ``noise_std``. A different value simulates a tracker
      that is told the wrong noise.
    - ``p_detect``: detection probability (default 1.0).
    - ``clutter_rate``: mean clutter detections per frame (default 0.0).
    - ``drift``: the sensor's drift over an episode (`track_envs.envs.drift`): a
      [`SensorDrift`][track_envs.envs.SensorDrift], a mapping or a preset name (``"belt"``); its noise
      std replaces ``noise_std`` as the noise added, and ``sensor_spec`` keeps the nominal values.
      ``info["sensor"]`` holds each frame's true ``noise_std``, ``p_detect``, ``clutter_rate``.
      Default None (no drift).
    - ``max_detections``: detection rows; ``max_tracks``: report rows; ``max_targets``: truth rows
      in ``info``. Each defaults to the rows the scene needs in a burst
      (`scene_rows`: the mean count in view from the feed rate
      and the particles' residence in the window, with margin, at least 256): 256 on the default
      belt, ≈17,700 on [`BeltParams.industrial()`][track_envs.envs.BeltParams.industrial].
    - ``overflow``: what a frame with more detections than ``max_detections`` or more particles
      in view than ``max_targets`` does. ``"grow"`` (default): the rows double until they fit,
      ``observation_space`` and ``action_space`` are rebuilt with them and a ``RuntimeWarning``
      names the count and the old and new sizes (nothing is dropped; an env under a vector env,
      whose spaces are fixed, should pass sizes that fit or ``"drop"``). ``"drop"``: the rows stay
      fixed, the surplus is dropped and counted in ``info["dropped_detections"]`` /
      ``info["dropped_targets"]``, warned once per episode.
    - ``feed_rate``: particles per second (default 195); ``belt_speed``: m/s (default 1.44).
    - ``physics``: a [`BeltParams`][track_envs.envs.BeltParams] for everything else;
      ``BeltParams.industrial()`` is an industrial-width belt (2 m wide, a 4 m window, ≈12,000
      particles in view: ``gym.make("BeltSorter-v0", physics=BeltParams.industrial())``), also
      asked for by name (``physics="industrial"``:
      `BELT_PRESETS`, e.g. from a bench suite's ``env_kwargs``).
    - ``gospa_c``: GOSPA cut-off in metres (default 0.005).
    - ``merge_touching``: touching particles give one detection at their area-weighted centroid
      (default ``True``); ``False`` senses every particle on its own, as v0 did before 2026-12-01.
    - ``merge_tolerance``: largest gap in metres between silhouettes that still counts as
      touching, in ``[0, 0.01]`` (default 1e-4).
    - ``nozzle_offset``: distance in metres from the end of the camera window to the nozzle bar,
      in ``(0, 0.25]`` (default 0.05); ``None``: no nozzle bar (no crossings, no
      ``sorting_line``, particles removed ``exit_margin`` past the window as before).
    - ``render_mode``: ``"rgb_array"`` or ``"human"``.

    ## Copying and pickling
    ``pickle`` and ``copy.deepcopy`` (of this env or of the ``gym.make`` wrappers around it) give
    an env that continues the episode bit for bit: the same observations, ``info`` and rewards
    as the original for the same reports, also in another process.

    pymunk copies a ``Space`` with its bodies, shapes and cached contacts (impulses included) but
    rebuilds what Chipmunk does not expose, the broad-phase tree and the contact list the solver
    works through. With 5 solver iterations the solver has not converged, so where it ends
    depends on that: in a bare pymunk scene of 200 touching discs a copy's velocities differ by
    2e-2 m/s after one step (1e-14 m/s at 100 iterations); on the belt, positions drift by
    2e-5 m on the next frame and 2 mm within 500. So the pickle holds no pymunk object. It holds
    the generator state at the start of the episode, the frames stepped since and a digest of
    the world (`digest`), and restoring rebuilds
    the world by replaying the scene: the warm-up, then each frame's world step and sensor draws.
    The replay is exact because the episode is a function of that generator state alone:
    reports are only scored, they move nothing and draw no random numbers. Restoring costs
    about as much as playing the episode to that frame again (``benchmarks/bench_belt_restore.py``;
    ≈0.4 s at the 1,500-frame limit), pickling itself is cheap and small (≈35 KB).

    When the replay does not reproduce the digest and the generator state, restoring raises
    ``RuntimeError`` rather than continue another episode: the world or ``np_random`` was
    changed outside ``reset`` and ``step``, or the pickle was made with other versions of numpy,
    numba or pymunk or on another kind of CPU. A world alone refuses to be pickled.

    ## Version History
    - v0: the first version. Its streams changed four times under v0 before
      the digests pinned them, and are pinned since 2026-12-02: on 2026-11-22 the belt was simulated in
      its rest frame (other floating-point bits), then a certain detection (``p_detect=1``, the
      default) stopped drawing a uniform number (the noise draws shifted); on 2026-12-01 touching
      particles became one detection (``merge_touching``, on by default; off gives the streams
      from before) and the nozzle bar came (``nozzle_offset`` = 0.05 m: particles are simulated
      until they pass it, so a seed's stream departs from the one before after a few dozen
      frames; ``None`` gives the streams from before). Added without changing the streams:
      ``measurement_noise_std``, ``drift`` (default None), copies and pickles that continue an
      episode bit for bit, observation sizes from the scene and ``overflow`` (256 rows on the
      default belt, as before; the pinned streams never overflow), ``BeltParams.industrial()``
      and the ``physics`` presets.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 100}  # noqa: RUF012

    def __init__(
        self,
        *,
        particle_kind: str | Mapping[str, float] = "cylinder",
        noise_std: float = 1e-4,
        measurement_noise_std: float | None = None,
        p_detect: float = 1.0,
        clutter_rate: float = 0.0,
        drift: SensorDrift | Mapping[str, Any] | str | None = None,
        max_detections: int | None = None,
        max_tracks: int | None = None,
        max_targets: int | None = None,
        feed_rate: float | None = None,
        belt_speed: float | None = None,
        physics: BeltParams | str | None = None,
        gospa_c: float = 0.005,
        merge_touching: bool = True,
        merge_tolerance: float = MERGE_TOLERANCE,
        nozzle_offset: float | None = DEFAULT_NOZZLE_OFFSET,
        overflow: str = "grow",
        render_mode: str | None = None,
    ):
        self.nozzle_offset = check_nozzle_offset(nozzle_offset)
        params = belt_preset(physics) if isinstance(physics, str) else physics
        params = params if params is not None else BeltParams()
        if not isinstance(params, BeltParams):
            raise ValueError(
                f"physics must be a BeltParams or a preset name {list(BELT_PRESETS)}, "
                f"got {type(params).__name__}"
            )
        self.physics = replace(
            params,
            feed_rate=params.feed_rate if feed_rate is None else check_non_negative("feed_rate", feed_rate),
            belt_speed=params.belt_speed if belt_speed is None else check_positive("belt_speed", belt_speed),
        )
        self.kinds = resolve_mixture(particle_kind)
        self.kind_names = list(self.kinds)
        rows = scene_rows(self.physics, self.kinds)
        max_detections = check_int("max_detections", rows if max_detections is None else max_detections, 1)
        max_tracks = check_int("max_tracks", rows if max_tracks is None else max_tracks, 1)
        max_targets = check_int("max_targets", rows if max_targets is None else max_targets, 1)
        self.gospa_c = check_positive("gospa_c", gospa_c)
        if not isinstance(merge_touching, bool | np.bool_):
            raise ValueError(f"merge_touching must be True or False, got {merge_touching!r}")
        self.merge_touching = bool(merge_touching)
        self.merge_tolerance = check_non_negative("merge_tolerance", merge_tolerance)
        if self.merge_tolerance > MAX_MERGE_TOLERANCE:
            raise ValueError(
                f"merge_tolerance must be a gap in [0, {MAX_MERGE_TOLERANCE}] m between silhouettes that "
                "still counts as touching (a larger one joins particles that are apart), "
                f"got {merge_tolerance!r}"
            )
        if overflow not in ("grow", "drop"):
            raise ValueError(f"overflow must be 'grow' or 'drop', got {overflow!r}")
        self.overflow = overflow
        self._silhouettes = silhouette_table(
            [
                (PARTICLE_KINDS[k].shape, PARTICLE_KINDS[k].length, PARTICLE_KINDS[k].width)
                for k in self.kind_names
            ],
            BOX_ROUNDING,
        )
        self._merged = np.full((0, MAX_MERGED), -1, dtype=np.int64)
        self._truncated_merge_ids = 0
        dt = 0.01
        p = self.physics
        added = check_non_negative("noise_std", noise_std)
        spec = SensorSpec(
            dt=dt,
            dim=2,
            noise_std=(
                added
                if measurement_noise_std is None
                else check_non_negative("measurement_noise_std", measurement_noise_std)
            ),
            p_detect=check_probability("p_detect", p_detect),
            clutter_rate=check_non_negative("clutter_rate", clutter_rate),
            region_low=(0.0, 0.0),
            region_high=(p.window_length, p.window_width),
            max_detections=int(max_detections),
            max_tracks=int(max_tracks),
            units="m",
            sorting_line=None if self.nozzle_offset is None else p.window_length + self.nozzle_offset,
        )
        self._set_drift(drift)
        margin = 10 * (self.drift.highest("noise_std", added) if self.drift else added) + 0.01
        self._setup_spaces(
            spec,
            added_noise_std=added,
            max_targets=max_targets,
            obs_low=np.array(spec.region_low) - margin,
            obs_high=np.array(spec.region_high) + margin,
            truth_extra_shapes={"velocities": (2,), "angles": (), "kinds": ()},
            render_mode=render_mode,
        )
        self.world: BeltWorld | None = None

    # -- simulation ---------------------------------------------------------------------------
    def _reset_scene(self) -> None:
        self._truncated_merge_ids = 0
        # the episode is a function of this generator state and the frame count (see __getstate__)
        self._scene_start: dict[str, Any] = dict(self.np_random.bit_generator.state)
        self.world = BeltWorld(
            self.physics,
            self.kinds,
            self.np_random,
            self.sensor_spec.dt,
            line_x=self.sensor_spec.sorting_line,
        )
        self.world.warm_up()
        self.world.crossings = (
            self.world.crossings[0][:0],
            *self.world.crossings[1:],
        )  # warm-up's: not shown

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

    def _sense(self, truth: Truth) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Detections of the blobs (merged touching particles) or, without merging, of each particle."""
        if not self.merge_touching:
            return super()._sense(truth)
        e = truth.extra
        centres, primary, self._merged, truncated = merge_blobs(
            truth.positions,
            truth.ids,
            e["angles"],
            e["kinds"],
            self._silhouettes,
            self.merge_tolerance,
            MAX_MERGED,
        )
        self._truncated_merge_ids += truncated
        return self._sense_points(centres, primary)

    def _observe(self, ended: bool = False) -> tuple[dict[str, NDArray], dict[str, Any]]:
        """The base observation with the merged ids of every detection row in ``info``."""
        self._merged = self._merged[:0]
        obs, info = super()._observe(ended)
        info["detection_ids_merged"] = merged_rows(info["detection_ids"], self._merged, MAX_MERGED)
        info["truncated_merge_ids"] = self._truncated_merge_ids
        return obs, info

    def _padded_truth(self, truth: Truth, m: int) -> dict[str, NDArray]:
        """The base class's padding in one compiled call (every particle in the window is visible)."""
        e = truth.extra
        ids, positions, visible, velocities, angles, kinds = padded_state(
            truth.ids, truth.positions, e["velocities"], e["angles"], e["kinds"], m, self.max_targets
        )
        assert self.world is not None
        crossed, fraction, lateral = self.world.crossings
        frame_start = (self._frame - 1) * self.sensor_spec.dt  # the crossings happened since frame - 1
        nozzle, dropped = pack_crossings(
            crossed, frame_start + fraction * self.sensor_spec.dt, lateral, self.max_targets
        )
        if dropped:
            warn_dropped_crossings(dropped, self._frame, self.max_targets)
        return {
            "ids": ids,
            "positions": positions,
            "visible": visible,
            "velocities": velocities,
            "angles": angles,
            "kinds": kinds,
            **nozzle,
        }

    def default_metrics(self) -> list[Any]:
        """The point metrics (association errors, CLEAR MOT, GOSPA) and, with a nozzle bar, the
        sorting prediction (``sorting_*`` keys,
        [`SortingPrediction`][track_envs.metrics.SortingPrediction])."""
        from track_envs.metrics.sorting import SortingPrediction

        metrics = super().default_metrics()
        if self.nozzle_offset is not None:
            metrics.append(SortingPrediction())
        return metrics

    # -- pickling and copying -----------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        """Everything but the pymunk world, which is replaced by how to replay it (see the class
        docstring, "Copying and pickling")."""
        state = super().__getstate__()
        world = state.pop("world")
        state["world"] = None
        if world is not None:
            state["_replay"] = _Replay(self._scene_start, self._frame, world.digest())
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        replay = state.pop("_replay", None)
        self.__dict__.update(state)
        if replay is not None:
            self._restore_by_replay(replay, state)

    def _restore_by_replay(self, replay: _Replay, state: dict[str, Any]) -> None:
        """Rebuild the world by re-running the episode's random stream: the scene from the
        generator state at its start, then ``frames`` times the world step and the observation
        (the sensor draws from the same generator); then check the result against the pickled
        world's digest and generator state, and put the pickled bookkeeping back."""
        bit_generator = getattr(np.random, replay.start["bit_generator"])()
        bit_generator.state = replay.start
        self._np_random = np.random.Generator(bit_generator)
        self._dropped_detections = self._dropped_targets = 0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # overflow warnings were given in the original episode
            self._frame = 0
            self._reset_scene()
            self._observe()
            for _ in range(replay.frames):
                self._advance()
                self._frame += 1
                self._observe()
        assert self.world is not None
        pickled_rng = state["_np_random"].bit_generator.state
        if self.world.digest() != replay.digest or self._np_random.bit_generator.state != pickled_rng:
            raise RuntimeError(
                f"cannot restore this {type(self).__name__}: replaying its episode from the start "
                f"({replay.frames} frames) did not reproduce the pickled state. The world or the "
                "env's np_random was changed outside reset() and step(), or the pickle was made "
                "with other versions of numpy, numba or pymunk, or on another kind of CPU"
            )
        for key, value in state.items():
            if key not in ("world", "_np_random"):  # the replayed world draws from the replayed generator
                setattr(self, key, value)

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        from track_envs.envs.rendering import Canvas

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
        from track_envs.envs.rendering import LegendEntry

        boxes = any(PARTICLE_KINDS[name].shape != "circle" for name in self.kind_names)
        return [
            LegendEntry("particle (truth)", "box" if boxes else "disc"),
            LegendEntry("detection", "cross", (0, 0, 0)),
            LegendEntry("track", "ring"),
            LegendEntry("camera window", "line", _WINDOW),
        ]

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        from track_envs.envs.rendering import identity_colors

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


class _Replay(NamedTuple):
    """How to rebuild a pickled world: the generator state at the episode's start, the frames
    stepped since, and the world's [`digest`][track_envs.envs.belt_physics.BeltWorld.digest]."""

    start: dict[str, Any]
    frames: int
    digest: bytes


def _box_corners(centers: NDArray, angles: NDArray, length: float, width: float) -> NDArray:
    """Corners (n, 4, 2) of rectangles of size length × width rotated by ``angles``."""
    local = 0.5 * np.array([[length, width], [-length, width], [-length, -width], [length, -width]])
    c, s = np.cos(angles), np.sin(angles)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (n, 2, 2)
    return centers[:, None, :] + np.einsum("nij,kj->nki", rot, local)
