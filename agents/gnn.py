"""Global nearest neighbour (GNN) multi-target tracker with a pluggable predictor (paper 000's tracker).

Every frame, for the ``n`` live tracks and the ``m`` detections of the observation:

1. **predict**: ``predictor.predict`` gives each track's predicted measurement ``N(ŷ_i, S_i)``;
2. **gate and associate**: squared Mahalanobis costs, χ² gate at ``p_gate``, Hungarian (or greedy)
   assignment with a per-track miss cost (:mod:`agents.association`);
   Tracks and detections left over get a second chance with every predicted covariance scaled by
   ``recovery_inflation``, so that a particle kicked out of its gate by a collision keeps its track;
3. **update / coast**: assigned tracks are corrected with their detection, the others coast;
4. **delete**: tracks with more than ``max_misses`` consecutive misses, and tracks that were not
   updated and whose predicted measurement has left the observed region (grown by ``region_margin``);
5. **initiate**: a new track from every detection left unassigned. Its velocity prior is learnt
   online (``velocity_prior="auto"``): the median and spread of the frame-to-frame velocities of
   young tracks (updated 3–6 times in a row), smoothed over frames — on a belt this is the flow
   where particles enter, so a track's second measurement is predicted where the flow takes it.

The report holds every live track at its current (posterior) estimate, and the detection row it
was updated with (−1 when it coasted). All per-frame work is batched over tracks and detections:
with the Kalman predictors, the filter steps, the gated costs and the per-track bookkeeping are
each one compiled loop (numba: :mod:`predictors._kalman_kernels`,
:mod:`agents._association_kernels`, :mod:`agents._gnn_kernels`), so a frame is a few dozen calls
whatever the number of tracks.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents import _gnn_kernels as _kernels
from agents.association import ASSOCIATORS, chi2_gate
from predictors import PREDICTORS, available_predictors, make_predictor
from predictors.base import Predictor, accepts_velocity_prior, reset_predictor
from track_envs.observation import check_observation
from track_envs.registry import UnknownArgumentError, check_keywords, missing_methods, named_arguments
from track_envs.report import pack_report
from track_envs.types import Gaussian, SensorSpec

#: Update streaks (consecutive updates) of the young tracks the velocity prior is learnt from.
YOUNG_STREAK = (3, 6)
#: Fewest young tracks in a frame for it to update the velocity prior.
MIN_YOUNG_TRACKS = 3


def _build_predictor(agent: type, predictor: Any, kwargs: dict[str, Any]) -> Any:
    """The predictor named ``predictor`` built with ``kwargs``, or the object ``predictor`` itself.

    Raises:
        UnknownArgumentError: for a keyword neither ``agent`` nor the named predictor takes (or any
            keyword with a predictor object), listing the arguments of both.
        ValueError: for an unknown predictor name, or an object lacking methods of the
            Predictor protocol (named).
    """
    own = named_arguments(agent)
    if isinstance(predictor, str):
        accepted = PREDICTORS.arguments(predictor)  # also refuses an unknown name
        if accepted is not None:
            note = (
                f", and it passes further keywords to predictor {predictor!r}, whose arguments are {accepted}"
            )
            check_keywords(agent.__name__, [k for k in kwargs if k not in accepted], own, note)
        return make_predictor(predictor, **kwargs)
    if kwargs:
        names = ", ".join(map(repr, kwargs))
        raise UnknownArgumentError(
            f"{agent.__name__} has no argument {names}; its arguments are {own} (further keywords go to "
            "a predictor given by name; configure a predictor object before passing it)"
        )
    missing = missing_methods(predictor, Predictor)
    if missing:
        raise ValueError(
            f"predictor must be a registered name {available_predictors()} or implement the Predictor "
            f"protocol (predictors.base.Predictor); {type(predictor).__name__} lacks {missing}"
        )
    return predictor


class GnnAgent:
    """Global nearest neighbour multi-target tracker: χ² gate, Hungarian, pluggable predictor (paper 000).

    Args:
        predictor: Registered predictor name (``"kf-ca"``, ``"kf-cv"``, ``"random-walk"``, ...) or an
            object implementing the Predictor protocol (its methods are checked here).
        p_gate: Gate probability of the χ² gate (paper 000: 0.999).
        assignment: ``"hungarian"`` (optimal) or ``"greedy"``.
        max_misses: A track is deleted after more than this many consecutive misses.
        region_margin: Tracks are deleted when their prediction leaves the observed region grown
            by this much (sensor units) on every side.
        velocity_prior: ``"auto"`` (learnt online, see the module docstring), ``None`` (the
            predictor's own default) or a fixed velocity (D,).
        recovery_inflation: Covariance scale of the second-chance association of leftover tracks
            and detections (1 turns it off).
        **predictor_kwargs: Passed to ``make_predictor`` when ``predictor`` is a name; a keyword
            that neither the agent nor that predictor takes raises
            :class:`~track_envs.registry.UnknownArgumentError` listing the arguments of both.
    """

    def __init__(
        self,
        predictor: str | Any = "kf-ca",
        *,
        p_gate: float = 0.999,
        assignment: str = "hungarian",
        max_misses: int = 2,
        region_margin: float = 0.0,
        velocity_prior: str | NDArray | None = "auto",
        recovery_inflation: float = 25.0,
        **predictor_kwargs: Any,
    ):
        if assignment not in ASSOCIATORS:
            raise ValueError(f"assignment must be one of {sorted(ASSOCIATORS)}, got {assignment!r}")
        if not (isinstance(max_misses, int) and max_misses >= 0):
            raise ValueError(f"max_misses must be an integer >= 0, got {max_misses!r}")
        if not (np.isfinite(region_margin) and region_margin >= 0):
            raise ValueError(f"region_margin must be a finite number >= 0, got {region_margin!r}")
        if isinstance(velocity_prior, str) and velocity_prior != "auto":
            raise ValueError(
                f"velocity_prior must be 'auto', None or a velocity vector, got {velocity_prior!r}"
            )
        self.predictor = _build_predictor(type(self), predictor, predictor_kwargs)
        self.predictor_name = predictor if isinstance(predictor, str) else type(predictor).__name__
        self.p_gate = p_gate
        self.assignment = assignment
        self._associate = ASSOCIATORS[assignment]
        self.max_misses = max_misses
        self.region_margin = region_margin
        self.velocity_prior = velocity_prior
        if not (np.isfinite(recovery_inflation) and recovery_inflation >= 1.0):
            raise ValueError(f"recovery_inflation must be a finite number >= 1, got {recovery_inflation!r}")
        self.recovery_inflation = float(recovery_inflation)
        self._gate = chi2_gate(p_gate, 1)  # re-derived for the sensor's dimension in reset()
        self._spec: SensorSpec | None = None

    # -- episode ------------------------------------------------------------------------------
    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start an episode with sensor ``spec`` (the tracker is deterministic; ``seed`` is unused)."""
        self._spec = spec
        reset_predictor(self.predictor, spec, np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0]))
        self._takes_velocity = accepts_velocity_prior(self.predictor)
        self._gate = chi2_gate(self.p_gate, spec.dim)
        self._state: Any = None
        self._ids = np.zeros(0, dtype=np.int64)
        self._misses = np.zeros(0, dtype=np.int64)
        self._streak = np.zeros(0, dtype=np.int64)
        self._last = np.zeros((0, spec.dim))
        self._next_id = 0
        self._flow_mean: NDArray | None = None
        self._flow_var: NDArray | None = None
        if self.velocity_prior is not None and not isinstance(self.velocity_prior, str):
            v = np.asarray(self.velocity_prior, dtype=np.float64)
            if v.shape != (spec.dim,):
                raise ValueError(f"velocity_prior must have shape ({spec.dim},), got {v.shape}")
            self._flow_mean = v
        lo = np.asarray(spec.region_low, dtype=np.float64) - self.region_margin
        hi = np.asarray(spec.region_high, dtype=np.float64) + self.region_margin
        self._region = (lo, hi)
        self.last_prediction: Gaussian | None = None
        self.last_prediction_ids = np.zeros(0, dtype=np.int64)
        self.last_prediction_detection = np.zeros(0, dtype=np.int64)

    @property
    def n_tracks(self) -> int:
        """Live tracks."""
        return len(self._ids)

    # -- one frame ----------------------------------------------------------------------------
    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """Consume one observation and report the live tracks."""
        if self._spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        spec = self._spec
        rows, z = check_observation(obs, spec)
        m = len(z)
        n = len(self._ids)
        if n == 0:
            new = np.arange(m)
            detection_rows = rows
        else:
            self._state, prediction = self.predictor.predict(self._state)
            self.last_prediction = prediction
            det_of_track = np.full(n, -1, dtype=np.int64)
            track_rows, det_cols = self._associate(prediction, z, self._gate)
            det_of_track[track_rows] = det_cols
            if len(track_rows) < min(n, m):  # tracks and detections left over on both sides
                self._recover(prediction, z, det_of_track)
            seen, self._misses, self._streak, keep, n_keep, young, n_young, new = _kernels.frame_upkeep(
                det_of_track,
                self._misses,
                self._streak,
                np.ascontiguousarray(prediction.mean, dtype=np.float64),
                self._region[0],
                self._region[1],
                self.max_misses,
                YOUNG_STREAK,
                m,
            )
            # rows of coasting tracks (detection −1) are never read by the update
            z_tracks = z[det_of_track] if m else np.zeros((n, spec.dim))
            self._state = self.predictor.update(self._state, z_tracks, seen)
            # for tracker-side metrics (prediction error, NEES): what was predicted for which track,
            # and the observation row it was then updated with (-1: coasted)
            self.last_prediction_ids = self._ids.copy()
            self.last_prediction_detection = _observation_rows(det_of_track, rows)
            estimate = np.asarray(self.predictor.estimate(self._state).mean)
            if n_young >= MIN_YOUNG_TRACKS:
                self._learn_flow(estimate, young)
            detection_rows = self.last_prediction_detection
            if n_keep < n:
                self._state = self._state.take(keep)
                self._ids, self._misses, self._streak = (
                    self._ids[keep],
                    self._misses[keep],
                    self._streak[keep],
                )
                detection_rows, estimate = detection_rows[keep], estimate[keep]
            self._last = estimate
            if len(new):
                detection_rows = np.concatenate([detection_rows, rows[new]])
        if len(new):
            self._initiate(z[new])
        return pack_report(self._ids, self._last, detection_rows, spec.max_tracks)

    def _recover(self, prediction: Gaussian, z: NDArray[np.float64], det_of_track: NDArray[np.int64]) -> None:
        """Second-chance association of the tracks and detections left over, with inflated gates.

        A collision or a kick moves a particle outside its track's gate; before that detection
        starts a new track, the leftovers are matched once more with every predicted covariance
        scaled by ``recovery_inflation`` (in place on ``det_of_track``). Called when there are
        leftovers on both sides.
        """
        if self.recovery_inflation <= 1.0:
            return
        used = np.zeros(len(z), dtype=bool)
        used[det_of_track[det_of_track >= 0]] = True
        tracks = np.flatnonzero(det_of_track < 0)
        dets = np.flatnonzero(~used)
        loose = Gaussian(prediction.mean[tracks], prediction.cov[tracks] * self.recovery_inflation)
        rows, cols = self._associate(loose, z[dets], self._gate)
        det_of_track[tracks[rows]] = dets[cols]

    def _initiate(self, z: NDArray[np.float64]) -> None:
        """New tracks at detections ``z`` (k, D), with the learnt velocity prior when there is one."""
        k = len(z)
        if self._takes_velocity and self.velocity_prior is not None and self._flow_mean is not None:
            mean = np.broadcast_to(self._flow_mean, z.shape).copy()
            cov = None
            if self._flow_var is not None:
                # the spread of young tracks, doubled, with a floor of 10% of the flow speed: the
                # prior must admit the particle that deviates, not just the typical one
                var = 4.0 * self._flow_var + (0.1 * np.linalg.norm(self._flow_mean)) ** 2
                cov = np.broadcast_to(np.diag(var), (k, len(var), len(var))).copy()
            born = self.predictor.start(z, velocity=mean, velocity_cov=cov)
        else:
            born = self.predictor.start(z)
        self._state = (
            born if self._state is None or self.n_tracks == 0 else type(born).concat([self._state, born])
        )
        self._ids = np.concatenate([self._ids, np.arange(self._next_id, self._next_id + k, dtype=np.int64)])
        self._next_id += k
        self._misses = np.concatenate([self._misses, np.zeros(k, dtype=np.int64)])
        self._streak = np.concatenate([self._streak, np.ones(k, dtype=np.int64)])
        self._last = np.concatenate([self._last, z])

    def _learn_flow(self, estimate: NDArray[np.float64], young: NDArray[np.bool_]) -> None:
        """Update the velocity prior from the ``young`` tracks (updated 3–6 frames in a row).

        New tracks are born where young tracks were born a few frames ago, so the velocities of
        young tracks are the right prior for them (on a belt: the entry speed, not the mean flow).
        """
        learning = isinstance(self.velocity_prior, str) and self.velocity_prior == "auto"
        if not learning or self._spec is None:
            return
        v = (estimate[young] - self._last[young]) / self._spec.dt
        median, spread = _kernels.median_and_mad_variance(np.ascontiguousarray(v, dtype=np.float64))
        if self._flow_mean is None or self._flow_var is None:
            self._flow_mean, self._flow_var = median, spread
        else:
            self._flow_mean = 0.9 * self._flow_mean + 0.1 * median
            self._flow_var = 0.9 * self._flow_var + 0.1 * spread


def _observation_rows(det_index: NDArray[np.int64], rows: NDArray[np.intp]) -> NDArray[np.int64]:
    """Observation rows of detection indices (-1 stays -1), safe when there are no detections."""
    row_of = np.empty(len(rows) + 1, dtype=np.int64)
    row_of[:-1] = rows
    row_of[-1] = -1  # what index -1 picks
    return row_of[det_index]
