"""The shared plumbing of every tracking environment: padding, shuffling, truth, report, reward.

A concrete environment only simulates and senses. It implements the abstract hooks (a subclass
that lacks one cannot be instantiated: ``TypeError`` names it)

* [`TrackingEnv._reset_scene`][track_envs.envs.base.TrackingEnv._reset_scene] — build the scene from
``self.np_random``;
* [`TrackingEnv._advance`][track_envs.envs.base.TrackingEnv._advance] — move the scene one frame on, return
``True`` when it has ended;
* [`TrackingEnv._truth`][track_envs.envs.base.TrackingEnv._truth] — the targets of the current frame as a
[`Truth`][track_envs.envs.Truth];
* [`TrackingEnv._canvas`][track_envs.envs.base.TrackingEnv._canvas] — the [`Canvas`][track_envs.envs.Canvas] a
frame is drawn on;
* [`TrackingEnv._draw`][track_envs.envs.base.TrackingEnv._draw] — a snapshot onto that canvas;

and may override

* [`TrackingEnv._sense`][track_envs.envs.base.TrackingEnv._sense] — the detections of the current frame and
the truth id behind each
  (default: the point sensor over the visible targets);
* [`TrackingEnv._snapshot`][track_envs.envs.base.TrackingEnv._snapshot] — what
[`TrackingEnv._draw`][track_envs.envs.base.TrackingEnv._draw] needs of the current frame
  (default: the current [`Truth`][track_envs.envs.Truth]);

and this base class does the rest of the contract of docs/architecture.md: the ``Dict`` observation
(padded detections + mask, rows shuffled with the env's RNG every frame so that row order never
reveals identity), the report action and its validation, ``info`` with the truth and the
per-detection ``detection_ids``, the per-frame reward, rendering of detections and reported tracks.

Step semantics: ``obs_t = reset()`` or ``step()`` shows frame ``t``; ``step(report_t)`` scores
``report_t`` against the truth of frame ``t`` (the reward), advances to frame ``t + 1`` and returns
its observation. When the scene has ended, ``step`` returns ``terminated=True`` with an empty
observation and empty truth.
"""

from __future__ import annotations

import abc
import warnings
from dataclasses import dataclass, field, replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from track_envs.contracts.report import Report, report_space, validate_report
from track_envs.envs.drift import DriftProcess, SensorDrift, SensorValues, resolve_drift
from track_envs.infra.arguments import check_int
from track_envs.infra.compiled import njit
from track_envs.metrics.gospa import gospa
from track_envs.values.types import SensorSpec


@dataclass(frozen=True)
class Truth:
    """The targets of one frame (unpadded).

    Attributes:
        ids: (m,) int64 truth ids.
        positions: (m, *P) float64 positions (P = (D,) for point targets).
        visible: (m,) bool, whether each target is in view of the sensor.
        extra: Further per-target arrays (m, ...) that go into ``info["truth"]`` by name
            (e.g. ``"velocities"``).
        all_visible: ``True`` promises that every target is visible, so that consumers may skip
            the mask (see [`all_in_view`][track_envs.envs.Truth.all_in_view]).
    """

    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    visible: NDArray[np.bool_]
    extra: dict[str, NDArray] = field(default_factory=dict)
    all_visible: bool = False

    @classmethod
    def all_in_view(
        cls, ids: NDArray[np.int64], positions: NDArray[np.float64], extra: dict[str, NDArray] | None = None
    ) -> Truth:
        """Truth of a frame whose every target is visible (the visible subset is the whole)."""
        return cls(ids, positions, np.ones(len(ids), dtype=bool), extra or {}, all_visible=True)

    def visible_part(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Ids and positions of the visible targets."""
        if self.all_visible:
            return self.ids, self.positions
        return self.ids[self.visible], self.positions[self.visible]


class TrackingEnv(gym.Env[dict[str, Any], dict[str, Any]], abc.ABC):
    """Base class of the tracking environments (see the module docstring).

    Subclasses call `_setup_spaces` once in ``__init__``
    after they know their sensor.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 30}  # noqa: RUF012

    sensor_spec: SensorSpec
    max_targets: int
    position_shape: tuple[int, ...]
    detection_shape: tuple[int, ...]
    truth_extra_shapes: dict[str, tuple[int, ...]]
    gospa_c: float
    #: Shuffle the detection rows every frame (a replay may keep its file's order).
    shuffle_rows: bool = True
    #: What a frame with more detections than ``max_detections`` (or targets than ``max_targets``)
    #: does: ``"drop"`` keeps the rows fixed, drops the surplus and counts it in ``info``
    #: (``dropped_detections``, ``dropped_targets``; warned once per episode); ``"grow"`` doubles
    #: the rows until they fit, rebuilds ``observation_space`` and ``action_space`` (warned).
    overflow: str = "drop"
    #: The sensor's drift over an episode ([`track_envs.envs.drift`][track_envs.envs.drift]); None: it stays
    #: nominal.
    drift: SensorDrift | None = None
    _drift_process: DriftProcess | None = None

    # -- set-up -------------------------------------------------------------------------------
    def _setup_spaces(
        self,
        spec: SensorSpec,
        *,
        max_targets: int,
        obs_low: ArrayLike,
        obs_high: ArrayLike,
        position_shape: tuple[int, ...] | None = None,
        detection_shape: tuple[int, ...] | None = None,
        truth_extra_shapes: dict[str, tuple[int, ...]] | None = None,
        render_mode: str | None = None,
        added_noise_std: float | None = None,
    ) -> None:
        """Build the spaces and per-episode state.

        ``added_noise_std`` is the noise the default [`_sense`][track_envs.envs.base.TrackingEnv._sense] adds;
        ``None`` adds what the sensor spec declares (``spec.noise_std``). Envs that replay real measurements
        add less (often none) than they declare.
        """
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.sensor_spec = spec
        self.added_noise_std = float(spec.noise_std if added_noise_std is None else added_noise_std)
        self.max_targets = check_int("max_targets", max_targets, 1)
        self.position_shape = position_shape or (spec.dim,)
        self.detection_shape = detection_shape or (spec.dim,)
        self.truth_extra_shapes = truth_extra_shapes or {}
        self._obs_bounds = (np.asarray(obs_low, dtype=np.float32), np.asarray(obs_high, dtype=np.float32))
        self._build_spaces(spec)
        self._frame = -1
        self._mask = np.zeros(spec.max_detections, dtype=np.int8)
        self._current_truth: Truth | None = None
        self._last_report: Report | None = None
        self._last_detections: NDArray[Any] = np.zeros((0, *self.detection_shape))
        self._dropped_detections = 0
        self._dropped_targets = 0
        self._window: Any = None
        # (snapshot, detections, report, frame index) of the frame render() draws
        self._render_frame: tuple[Any, NDArray, Report | None, int] | None = None

    def _build_spaces(self, spec: SensorSpec) -> None:
        """The observation and action spaces of ``spec`` (its rows), and the clutter box."""
        self.sensor_spec = spec
        det_shape = (spec.max_detections, *self.detection_shape)
        # the bounds always contain 0: padding rows are zero
        self._obs_low = np.broadcast_to(np.minimum(self._obs_bounds[0], 0), det_shape)
        self._obs_high = np.broadcast_to(np.maximum(self._obs_bounds[1], 0), det_shape)
        self._row_low = np.ascontiguousarray(self._obs_low[0].reshape(-1), dtype=np.float64)
        self._row_high = np.ascontiguousarray(self._obs_high[0].reshape(-1), dtype=np.float64)
        self.observation_space = spaces.Dict(
            {
                "detections": spaces.Box(self._obs_low, self._obs_high, dtype=np.float32),
                "mask": spaces.Box(0, 1, shape=(spec.max_detections,), dtype=np.int8),
            }
        )
        lo = np.asarray(spec.region_low, dtype=np.float64)
        hi = np.asarray(spec.region_high, dtype=np.float64)
        self._clutter_low, self._clutter_high = lo, hi
        span = hi - lo
        self.action_space = report_space(
            spec.max_tracks,
            self.position_shape,
            np.minimum(lo - span, 0),
            np.maximum(hi + span, 0),
            spec.max_detections,
        )

    def _grow_detection_rows(self, needed: int) -> None:
        """Double ``max_detections`` until ``needed`` rows fit, and rebuild the spaces (warned)."""
        old = self.sensor_spec.max_detections
        rows = old
        while rows < needed:
            rows *= 2
        warnings.warn(
            f"{needed} detections in frame {self._frame} exceed max_detections={old}; the observation "
            f"grows to {rows} rows and observation_space / action_space are rebuilt with them (pass "
            f"max_detections >= {needed}, or overflow='drop' to keep the rows fixed)",
            RuntimeWarning,
            stacklevel=4,
        )
        self._build_spaces(replace(self.sensor_spec, max_detections=rows))
        self._mask = np.zeros(rows, dtype=np.int8)

    def _follow_report_rows(self, action: Any) -> None:
        """With ``overflow="grow"``, a report with more rows than ``max_tracks`` (a tracker that
        outgrew it, [`PointTracker`][agents.PointTracker]) makes them ``max_tracks``:
        the action space is rebuilt and a ``RuntimeWarning`` names the sizes."""
        mask = action.get("mask") if isinstance(action, dict) else None
        rows = int(np.shape(mask)[0]) if mask is not None and np.ndim(mask) == 1 else 0
        old = self.sensor_spec.max_tracks
        if self.overflow != "grow" or rows <= old:
            return
        warnings.warn(
            f"a report of {rows} rows in frame {self._frame} exceeds max_tracks={old}; max_tracks grows to "
            f"{rows} and action_space is rebuilt (pass max_tracks >= {rows} to keep it fixed)",
            RuntimeWarning,
            stacklevel=4,
        )
        self._build_spaces(replace(self.sensor_spec, max_tracks=rows))

    def _set_drift(self, drift: SensorDrift | Any) -> None:
        """Let the sensor drift ([`track_envs.envs.drift.resolve_drift`][track_envs.envs.resolve_drift] checks
        ``drift``)."""
        self.drift = resolve_drift(drift)

    def _nominal_sensor(self) -> SensorValues:
        """The sensor's nominal values: the noise added, the spec's p_detect and clutter rate."""
        spec = self.sensor_spec
        return SensorValues(self.added_noise_std, spec.p_detect, spec.clutter_rate)

    def _sensor_now(self) -> SensorValues:
        """The true sensor values of the current frame: nominal, or the drift's."""
        if self._drift_process is None:
            return self._nominal_sensor()
        return self._drift_process.at(max(self._frame, 0))

    # -- hooks for subclasses -----------------------------------------------------------------
    @abc.abstractmethod
    def _reset_scene(self) -> None:
        """Build the scene of a new episode, drawing every random number from ``self.np_random``."""

    @abc.abstractmethod
    def _advance(self) -> bool:
        """Move the scene one frame on.

        Returns:
            ``True`` when the scene has ended (``step`` then returns ``terminated=True``).
        """

    @abc.abstractmethod
    def _truth(self) -> Truth:
        """The targets of the current frame (unpadded; the base class pads them into ``info``)."""

    def _sense(self, truth: Truth) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Point sensor over the visible targets, clutter uniform over the observed region.

        The noise added is ``added_noise_std`` (see
        [`_setup_spaces`][track_envs.envs.base.TrackingEnv._setup_spaces]), by default the sensor spec's
        ``noise_std``; with a drift, the noise, detection probability and clutter rate of the frame's drift
        ([`_sensor_now`][track_envs.envs.base.TrackingEnv._sensor_now]).

        Point environments use this as it is; others override it (see
        [`track_envs.envs.sensors`][track_envs.envs.sensors]).
        """
        ids, positions = truth.visible_part()
        return self._sense_points(positions, ids)

    def _sense_points(
        self, positions: NDArray[np.float64], ids: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The point sensor (noise, misses, clutter) over sources at ``positions`` with ``ids``."""
        from track_envs.envs.sensors import sense_points

        now = self._sensor_now()
        return sense_points(
            positions,
            ids,
            self.np_random,
            noise_std=now.noise_std,
            p_detect=now.p_detect,
            clutter_rate=now.clutter_rate,
            clutter_low=self._clutter_low,
            clutter_high=self._clutter_high,
        )

    def _score(self, truth: Truth, report: Report) -> float:
        """Reward of ``report``: −GOSPA (c = ``gospa_c``, p = 2, α = 2) against the visible targets."""
        _, visible = truth.visible_part()
        return -gospa(visible, report.positions, self.gospa_c, 2.0).distance

    def default_metrics(self) -> list[Any]:
        """The streaming metrics that fit this environment (used by ``TrackingMetrics``).

        Point environments score association errors, CLEAR MOT and GOSPA; other families override.
        """
        from track_envs.wrappers.tracking_metrics import point_metrics

        return point_metrics(self.gospa_c)

    def _snapshot(self) -> Any:
        """Whatever [`_draw`][track_envs.envs.base.TrackingEnv._draw] needs of the current frame (copied: the
        scene moves on)."""
        return self._current_truth

    @abc.abstractmethod
    def _draw(self, canvas: Any, snapshot: Any) -> None:
        """Draw ``snapshot`` (of [`_snapshot`][track_envs.envs.base.TrackingEnv._snapshot]) onto ``canvas``
        (of [`_canvas`][track_envs.envs.base.TrackingEnv._canvas])."""

    @abc.abstractmethod
    def _canvas(self) -> Any:
        """A fresh [`Canvas`][track_envs.envs.Canvas] of the scene's region to draw a frame on."""

    def _draw_overlay(self, canvas: Any, detections: NDArray, report: Report | None) -> None:
        """Detections as black crosses, the report's tracks as rings in their id colours (see
        [`_legend`][track_envs.envs.base.TrackingEnv._legend])."""
        from track_envs.envs.rendering import identity_colors

        if len(detections):
            canvas.crosses(detections, 4, (0, 0, 0))
        if report is not None and len(report):
            canvas.rings(report.positions, 7, identity_colors(report.ids), thickness_px=2)

    def _legend(self) -> list[Any]:
        """The footer's legend: how [`_draw`][track_envs.envs.base.TrackingEnv._draw] and
        [`_draw_overlay`][track_envs.envs.base.TrackingEnv._draw_overlay] show each thing."""
        from track_envs.envs.rendering import LegendEntry

        return [
            LegendEntry("truth", "disc"),
            LegendEntry("detection", "cross", (0, 0, 0)),
            LegendEntry("track", "ring"),
        ]

    def _keep_for_rendering(self, report: Report | None) -> None:
        """Remember the current frame and the report that answers it (only when rendering)."""
        if self.render_mode is not None:
            self._render_frame = (self._snapshot(), self._last_detections.copy(), report, self._frame)

    # -- gymnasium API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray], dict[str, Any]]:
        super().reset(seed=seed)
        self._frame = 0
        self._drift_process = None
        if self.drift is not None:  # one draw, and only with a drift: other streams are unchanged
            seed_drift = int(self.np_random.integers(2**63 - 1))
            self._drift_process = DriftProcess(self.drift, self._nominal_sensor(), seed_drift)
        self._last_report = None
        self._dropped_detections = 0
        self._dropped_targets = 0
        self._reset_scene()
        obs, info = self._observe()
        self._keep_for_rendering(None)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(
        self, action: dict[str, NDArray]
    ) -> tuple[dict[str, NDArray], float, bool, bool, dict[str, Any]]:
        if self._frame < 0 or self._current_truth is None:
            raise RuntimeError("step() called before reset(); call env.reset(seed=...) first")
        self._follow_report_rows(action)
        report = validate_report(action, self.sensor_spec.max_tracks, self.position_shape, self._mask)
        reward = float(self._score(self._current_truth, report))
        self._last_report = report
        self._keep_for_rendering(report)
        terminated = bool(self._advance())
        self._frame += 1
        obs, info = self._observe(ended=terminated)
        if terminated:
            self._current_truth = None
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    # -- observation and info -----------------------------------------------------------------
    def _observe(self, ended: bool = False) -> tuple[dict[str, NDArray], dict[str, Any]]:
        spec = self.sensor_spec
        if ended:
            truth = self._empty_truth()
            z = np.zeros((0, *self.detection_shape))
            source = np.zeros(0, dtype=np.int64)
        else:
            truth = self._truth()
            z, source = self._sense(truth)
        order = self.np_random.permutation(len(z)) if self.shuffle_rows else np.arange(len(z))
        if len(order) > spec.max_detections and self.overflow == "grow":
            self._grow_detection_rows(len(order))
            spec = self.sensor_spec
        if len(order) > spec.max_detections:
            if not self._dropped_detections:
                warnings.warn(
                    f"{len(order)} detections in frame {self._frame} exceed max_detections="
                    f"{spec.max_detections}; the surplus (random rows) is dropped and counted in "
                    "info['dropped_detections'] (warned once per episode)",
                    RuntimeWarning,
                    stacklevel=3,
                )
            self._dropped_detections += len(order) - spec.max_detections
            order = order[: spec.max_detections]
        k = len(order)
        flat, mask, detection_ids = _padded_rows(
            np.asarray(z, dtype=np.float64).reshape(len(z), len(self._row_low)),
            np.asarray(source, dtype=np.int64),
            order,
            self._row_low,
            self._row_high,
            spec.max_detections,
        )
        detections = flat.reshape(spec.max_detections, *self.detection_shape)
        self._mask = mask
        self._current_truth = truth
        self._last_detections = detections[:k]
        obs: dict[str, NDArray[Any]] = {"detections": detections, "mask": mask}
        info: dict[str, Any] = {
            "t": self._frame * spec.dt,
            "frame": self._frame,
            "truth": self._pack_truth(truth),
            "detection_ids": detection_ids,
            "dropped_detections": self._dropped_detections,
            "dropped_targets": self._dropped_targets,
        }
        if self._drift_process is not None:
            info["sensor"] = self._sensor_now()._asdict()  # the true values of this frame
        return obs, info

    def _empty_truth(self) -> Truth:
        return Truth(
            ids=np.zeros(0, dtype=np.int64),
            positions=np.zeros((0, *self.position_shape)),
            visible=np.zeros(0, dtype=bool),
            extra={k: np.zeros((0, *s)) for k, s in self.truth_extra_shapes.items()},
        )

    def _pack_truth(self, truth: Truth) -> dict[str, NDArray]:
        m = len(truth.ids)
        if m > self.max_targets and self.overflow == "grow":
            rows = self.max_targets
            while rows < m:
                rows *= 2
            warnings.warn(
                f"{m} targets in frame {self._frame} exceed max_targets={self.max_targets}; the rows of "
                f"info['truth'] grow to {rows} (pass max_targets >= {m} to keep them fixed)",
                RuntimeWarning,
                stacklevel=4,
            )
            self.max_targets = rows
        cap = self.max_targets
        if m > cap:
            if not self._dropped_targets:
                warnings.warn(
                    f"{m} targets in frame {self._frame} exceed max_targets={cap}; info['truth'] holds the "
                    f"first {cap} by id and the rest is counted in info['dropped_targets'] (warned once "
                    "per episode)",
                    RuntimeWarning,
                    stacklevel=4,
                )
            self._dropped_targets += m - cap
            m = cap
        return self._padded_truth(truth, m)

    def _padded_truth(self, truth: Truth, m: int) -> dict[str, NDArray]:
        """The first ``m`` targets of ``truth`` padded to ``max_targets`` rows (ids -1, the rest 0)."""
        cap = self.max_targets
        packed = {
            "ids": _padded(truth.ids, m, (cap,), -1, np.int64),
            "positions": _padded(truth.positions, m, (cap, *self.position_shape), 0, np.float64),
            "visible": _padded(truth.visible, m, (cap,), False, np.bool_),
        }
        for name, shape in self.truth_extra_shapes.items():
            arr = np.asarray(truth.extra[name])
            packed[name] = _padded(arr, m, (cap, *shape), 0, arr.dtype)
        return packed

    # -- rendering ----------------------------------------------------------------------------
    def render(self) -> NDArray[np.uint8] | None:
        """Draw the last frame reported on: its scene, its detections (crosses) and the tracks of
        the report that answered it (rings); before the first step, the first frame. A footer under
        the scene gives the frame number, its time and the legend.

        Returns:
            ``rgb_array``: the ``uint8`` frame (H, W, 3); ``human``: ``None`` (the frame is shown in
                a pygame window).
        """
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to gym.make")
            return None
        if self._frame < 0:
            raise RuntimeError("render() called before reset()")
        if self._render_frame is None:
            self._keep_for_rendering(None)
        assert self._render_frame is not None
        snapshot, detections, report, index = self._render_frame
        canvas = self._canvas()
        self._draw(canvas, snapshot)
        self._draw_overlay(canvas, detections, report)
        canvas.footer(f"frame {index}   t = {index * self.sensor_spec.dt:.3f} s", self._legend())
        frame = canvas.to_array()
        if self.render_mode == "human":
            if self._window is None:
                from track_envs.envs.render_window import HumanWindow

                self._window = HumanWindow(type(self).__name__, int(self.metadata["render_fps"]))
            self._window.show(frame)
            return None
        return frame

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None
        return state


def _padded(values: NDArray, m: int, shape: tuple[int, ...], fill: Any, dtype: Any) -> NDArray:
    """The first ``m`` rows of ``values`` in a new array of ``shape``, the rest ``fill``."""
    out = np.zeros(shape, dtype=dtype) if fill == 0 else np.full(shape, fill, dtype=dtype)
    out[:m] = values[:m]
    return out


@njit(cache=True)
def _padded_rows(
    z: NDArray[np.float64],
    source: NDArray[np.int64],
    order: NDArray[np.int64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    max_rows: int,
) -> tuple[NDArray[np.float32], NDArray[np.int8], NDArray[np.int64]]:
    """Rows ``z[order]`` clipped to ``[low, high]`` and zero-padded to ``max_rows`` (float32), with
    the mask and the truth id behind each row (-1 on padding)."""
    n_cols = z.shape[1]
    detections = np.zeros((max_rows, n_cols), dtype=np.float32)
    mask = np.zeros(max_rows, dtype=np.int8)
    ids = np.full(max_rows, -1, dtype=np.int64)
    for i in range(len(order)):
        row = order[i]
        for c in range(n_cols):
            detections[i, c] = min(max(z[row, c], low[c]), high[c])
        mask[i] = 1
        ids[i] = source[row]
    return detections, mask, ids
