"""The point tracker: a track table and its life cycle, composed with an associator.

Every frame, for the ``n`` live tracks and the ``m`` detections of the observation:

1. **predict**: ``predictor.predict`` gives each track's predicted measurement ``N(ŷ_i, S_i)``;
2. **associate**: the [`Associator`][agents.Associator] component gets a read-only
   [`FrameContext`][agents.FrameContext] (predictions, detections, the χ² gate at
   ``p_gate``, the tracks' streaks and last estimates, the stream's motion, the noise) and returns
   an [`Association`][agents.Association]: the detection of every track and the
   measurement it is updated with (gnn's gated assignment with the capped second chance,
   [`agents.tracking.gated`][agents.tracking.gated]; jpda's marginals,
   [`agents.jpda.associator`][agents.jpda.associator]; ...);
3. **update / coast**: the associator corrects the tracks it found detected
   ([`update`][agents.Associator.update]), the others coast;
4. **delete**: tracks with more than ``max_misses`` consecutive misses, and tracks that were not
   updated and whose predicted measurement has left the observed region (grown by ``region_margin``);
5. **initiate**: a new track from every detection left unassigned that the association lets start
   one, with the velocity prior ([`agents.tracking.velocity_prior`][agents.tracking.velocity_prior]: learnt
   online from the young tracks with ``velocity_prior="auto"``, fixed, or none; ``velocity_fallback`` until it
   is learnt). [`PointTracker.velocity_prior_state`][agents.PointTracker.velocity_prior_state] shows the
   prior.

The report holds every live track at its current (posterior) estimate, and the detection row it
was updated with (−1 when it coasted). When the sensor has a nozzle bar downstream
(``SensorSpec.sorting_line``, BeltSorter-v0), every track deleted in a frame gets a predicted
crossing of the bar in the report's sorting channel
([`track_envs.contracts.sorting_channel`][track_envs.contracts.sorting_channel]): its predictor rolled forward
from the track's state without further measurements
([`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings]; a track slower than a sixth
of the flow is given up, see
[`PointTracker._rollout_steps`][agents.tracking.tracker.PointTracker._rollout_steps]). A deleted track has
coasted since its last update, and coasting is that roll-out, so the prediction is the one from the last
update.

The sizes follow the scene: an observation with more rows than the spec's ``max_detections`` (an
env with ``overflow="grow"`` that grew its rows) is read as it is, and more live tracks than
``max_tracks`` grow the report (doubled until they fit, a ``RuntimeWarning`` once per episode; the
env follows the report's rows), as ``track run``'s reports grow — no track is dropped.

All per-frame work is batched over tracks and detections: with the Kalman predictors, the filter
steps, the start states, the gated costs, the second-chance costs and the per-track bookkeeping
are each one compiled loop (numba: [`predictors.kalman._kernels`][predictors.kalman._kernels],
[`agents.tracking._kernels`][agents.tracking._kernels],
[`agents.tracking._upkeep_kernels`][agents.tracking._upkeep_kernels]), so a frame is a few dozen calls
whatever the number of tracks. The kernels compile (or load from numba's cache) on first use;
[`PointTracker.warm_up`][agents.PointTracker.warm_up] runs every one of them once on a tiny synthetic input,
so that a live stream does not pause on its first frames.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import AgentCapability, AgentTraits
from agents.sorting.rollout import MAX_STEPS, predict_crossings
from agents.tracking import _upkeep_kernels as _kernels
from agents.tracking.assign import chi2_gate
from agents.tracking.associator import ASSOCIATOR_DECLARATIONS, Association, Associator, FrameContext
from agents.tracking.knobs import NOISE_SCALE, P_GATE, RECOVERY_INFLATION
from agents.tracking.velocity_prior import YOUNG_STREAK, FlowPrior, VelocityPriorState
from agents.tracking.warm_up import warm_up_stream
from predictors.base import Capability, Predictor, capability, reset_predictor
from predictors.registry import resolve_predictor
from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import pack_report, report_growth
from track_envs.contracts.sorting_channel import empty_sorting, pack_sorting
from track_envs.infra.registry import missing_methods
from track_envs.values.types import Gaussian, SensorSpec


def check_settings(
    predict_sorting: object, max_misses: object, region_margin: object, velocity_prior: object
) -> None:
    """Raise a ``ValueError`` naming the first of the tracker's settings that is not valid."""
    if not isinstance(predict_sorting, bool | np.bool_):
        raise ValueError(f"predict_sorting must be True or False, got {predict_sorting!r}")
    if not (isinstance(max_misses, int) and max_misses >= 0):
        raise ValueError(f"max_misses must be an integer >= 0, got {max_misses!r}")
    if isinstance(region_margin, bool) or not (
        isinstance(region_margin, int | float | np.integer | np.floating) and region_margin >= 0
    ):
        raise ValueError(
            f"region_margin must be a number >= 0 (inf: no region deletion), got {region_margin!r}"
        )
    if isinstance(velocity_prior, str) and velocity_prior != "auto":
        raise ValueError(f"velocity_prior must be 'auto', None or a velocity vector, got {velocity_prior!r}")


class PointTracker:
    """Multi-target point tracker: a pluggable predictor and a pluggable associator (module docstring).

    Args:
        predictor: Registered predictor name (``"kf-ca"``, ``"kf-cv"``, ``"random-walk"``, ...) or an
            object implementing the Predictor protocol (its methods are checked here).
        associator: The association component ([`Associator`][agents.Associator],
            e.g. ``make_associator("gnn")``).
        p_gate: Gate probability of the χ² gate (Pollithy et al. 2020: 0.999).
        max_misses: A track is deleted after more than this many consecutive misses.
        region_margin: Tracks are deleted when their prediction leaves the observed region grown
            by this much (sensor units) on every side; ``math.inf`` turns this deletion off.
        velocity_prior: ``"auto"`` (learnt online), ``None`` (the predictor's own default) or a
            fixed velocity (D,).
        recovery_inflation: Covariance scale of a second chance of leftover tracks and detections
            (1 turns it off; read by associators that offer one).
        velocity_fallback: With ``velocity_prior="auto"``, the velocity (D,) new tracks start from
            until the prior is learnt (e.g. the belt speed); None: the predictor's default.
        noise_scale: Factor ``k`` on the sensor's declared noise std that the predictor assumes
            (``R = (k σ)² I``), > 0. Needs a predictor that declares ``NOISE_SCALE`` unless it is 1.
        predict_sorting: With a nozzle bar in the sensor spec, report each deleted track's
            predicted crossing (default True); ``False`` skips the roll-outs.
        owner: The class or factory named in the errors of unknown keywords (default this class).
        **predictor_kwargs: Passed to ``make_predictor`` when ``predictor`` is a name.

    Live knobs: [`p_gate`][agents.PointTracker.p_gate],
    [`recovery_inflation`][agents.PointTracker.recovery_inflation] and
    [`noise_scale`][agents.PointTracker.noise_scale] may be set between frames of a running episode (each is
    checked, and the next frame uses it).
    """

    #: What every point tracker offers ([`agents.base.AgentCapability`][agents.AgentCapability]).
    capabilities = frozenset(
        {
            AgentCapability.WARM_UP,
            AgentCapability.TRACK_COVARIANCES,
            AgentCapability.LAST_PREDICTION,
            AgentCapability.SENSOR_MODEL,
        }
    )
    #: Built with ``predictor=`` (a Gaussian predictor's name or object).
    traits = AgentTraits(takes_predictor=True)

    def __init__(
        self,
        predictor: str | Predictor = "kf-ca",
        *,
        associator: Associator,
        p_gate: float = P_GATE.default,
        max_misses: int = 2,
        region_margin: float = 0.0,
        velocity_prior: str | NDArray | None = "auto",
        recovery_inflation: float = RECOVERY_INFLATION.default,
        velocity_fallback: NDArray | None = None,
        noise_scale: float = NOISE_SCALE.default,
        predict_sorting: bool = True,
        owner: Callable[..., Any] | None = None,
        **predictor_kwargs: Any,
    ):
        check_settings(predict_sorting, max_misses, region_margin, velocity_prior)
        missing = missing_methods(associator, Associator)
        if missing:
            raise ValueError(
                f"associator must implement the Associator protocol (agents.tracking.associator); "
                f"{type(associator).__name__} lacks {missing}"
            )
        ASSOCIATOR_DECLARATIONS.declared(associator)  # a malformed declaration is an error now
        self.associator = associator
        self.predict_sorting = bool(predict_sorting)
        self.predictor: Predictor = resolve_predictor(
            predictor, owner=type(self) if owner is None else owner, **predictor_kwargs
        )
        # the optional capabilities of the predictor this tracker uses (predictors.base), or None
        self._scalable = capability(self.predictor, Capability.NOISE_SCALE)
        self._with_prior = capability(self.predictor, Capability.VELOCITY_PRIOR)
        self._mean_only = capability(self.predictor, Capability.MEAN_ONLY_ESTIMATE)
        self._fused = capability(self.predictor, Capability.FUSED_SURVIVORS_BIRTHS)
        self.predictor_name = predictor if isinstance(predictor, str) else type(predictor).__name__
        self._spec: SensorSpec | None = None
        self.p_gate = p_gate
        self.max_misses = max_misses
        self.region_margin = region_margin
        self.velocity_prior = velocity_prior
        self.recovery_inflation = recovery_inflation
        self.noise_scale = noise_scale
        self.velocity_fallback = (
            None if velocity_fallback is None else np.asarray(velocity_fallback, np.float64)
        )

    # -- live knobs ---------------------------------------------------------------------------
    @property
    def p_gate(self) -> float:
        """Gate probability of the χ² gate; settable between frames (the gate follows at once)."""
        return self._p_gate

    @p_gate.setter
    def p_gate(self, value: float) -> None:
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
            raise ValueError(f"p_gate must be a probability in (0, 1), got {value!r}")
        dim = self._spec.dim if self._spec is not None else 1  # re-derived for the sensor in reset()
        self._gate = chi2_gate(float(value), dim)
        self._p_gate = float(value)

    @property
    def recovery_inflation(self) -> float:
        """Covariance scale of the second-chance association, >= 1; settable between frames."""
        return self._recovery_inflation

    @recovery_inflation.setter
    def recovery_inflation(self, value: float) -> None:
        self._recovery_inflation = RECOVERY_INFLATION.check(value)

    @property
    def noise_scale(self) -> float:
        """Factor ``k`` on the declared noise std the tracker assumes, > 0; settable between frames
        (the predictor's ``R`` and the second-chance cap follow at once)."""
        return self._noise_scale

    @noise_scale.setter
    def noise_scale(self, value: float) -> None:
        scale = NOISE_SCALE.check(value)
        if self._scalable is None and scale != 1.0:
            raise ValueError(
                f"noise_scale={value!r} needs a predictor with set_noise_scale (the NOISE_SCALE "
                f"capability: the Kalman filters); predictor {self.predictor_name!r} does not declare "
                "it, so noise_scale must stay 1"
            )
        if self._scalable is not None:
            self._scalable.set_noise_scale(scale)
        self._noise_scale = scale
        if self._spec is not None:
            self._noise = max(float(self._spec.noise_std) * scale, 1e-6)

    # -- episode ------------------------------------------------------------------------------
    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start an episode with sensor ``spec``.

        The tracker itself is deterministic; ``seed`` seeds the random stream handed to predictors
        that take one (``reset(spec, rng=...)``, e.g. mc-lstm's dropout masks), so the same seed
        gives the same report.
        """
        self._spec = spec
        reset_predictor(self.predictor, spec, np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0]))
        self._gate = chi2_gate(self.p_gate, spec.dim)
        self._state: Any = None
        self._ids = np.zeros(0, dtype=np.int64)
        self._misses = np.zeros(0, dtype=np.int64)
        self._streak = np.zeros(0, dtype=np.int64)
        self._last = np.zeros((0, spec.dim))
        self._detection_rows = np.zeros(0, dtype=np.int64)
        self._next_id = 0
        self._prior = FlowPrior(self.velocity_prior, self.velocity_fallback, spec.dim)
        self.associator.reset(spec, self.predictor)
        # the second chance's noise std, with the predictors' floor R >= (1 µm)²
        self._noise = max(float(spec.noise_std) * self.noise_scale, 1e-6)
        lo = np.asarray(spec.region_low, dtype=np.float64) - self.region_margin
        hi = np.asarray(spec.region_high, dtype=np.float64) + self.region_margin
        self._region = (lo, hi)
        self.last_prediction: Gaussian | None = None
        self.last_prediction_ids = np.zeros(0, dtype=np.int64)
        self.last_prediction_detection = np.zeros(0, dtype=np.int64)
        self._frame = 0
        self._grew = False
        sorting = spec.sorting_line is not None and self.predict_sorting
        self._no_sorting = empty_sorting(spec.max_tracks) if sorting else None
        self._sorting = self._no_sorting

    @property
    def n_tracks(self) -> int:
        """Live tracks."""
        return len(self._ids)

    def track_covariances(self) -> NDArray[np.float64]:
        """(n, D, D) covariance of every live track's current estimate, in the row order of the last
        report (the predictor's ``estimate(state).cov``, no measurement noise added)."""
        if self._spec is None:
            raise RuntimeError("track_covariances() needs reset(spec) first")
        if self._state is None or not len(self._ids):
            return np.zeros((0, self._spec.dim, self._spec.dim))
        return np.asarray(self.predictor.estimate(self._state).cov, dtype=np.float64)

    @property
    def velocity_prior_state(self) -> VelocityPriorState:
        """The velocity prior new tracks start from now: mean, spread, samples and where it comes from."""
        if self._spec is None:
            raise RuntimeError("velocity_prior_state needs reset(spec) first")
        return self._prior.state()

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel a frame can use, on a tiny synthetic stream.

        The first frames of a new process that start, associate or recover tracks otherwise pause
        for tens of milliseconds while the kernels load — frames a live sorter would drop. Call
        this once before the stream starts; it runs a throwaway copy of this tracker (its
        components copied) and leaves this one untouched, then the associator's own warm-up.
        """
        twin = copy.deepcopy(self)
        dim = self._spec.dim if self._spec is not None else 2
        spec, frames = warm_up_stream(dim, sorting=self.predict_sorting)
        twin.reset(spec)
        for obs in frames:
            twin.act(obs)
        self.associator.warm_up(dim)

    # -- one frame ----------------------------------------------------------------------------
    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """Consume one observation and report the live tracks."""
        if self._spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        self._follow_observation_rows(obs)
        rows, z = check_observation(obs, self._spec)
        if len(self._ids) == 0:
            self._initiate(z, rows, np.zeros(0, dtype=np.bool_), 0, np.zeros(0, dtype=np.int64), self._last)
            self._sorting = self._no_sorting
            return self._report()
        self._state, prediction = self.predictor.predict(self._state)
        self.last_prediction = prediction
        predicted = np.ascontiguousarray(prediction.mean, dtype=np.float64)
        association = self._associate_frame(prediction, predicted, z)
        det_of_track = association.det_of_track
        upkeep = _kernels.frame_upkeep(
            det_of_track,
            self._misses,
            self._streak,
            predicted,
            self._region[0],
            self._region[1],
            self.max_misses,
            YOUNG_STREAK,
            len(z),
        )
        self._misses, self._streak = upkeep.misses, upkeep.streak
        self._state = self._update_tracks(self._state, association, upkeep.seen)
        if self._no_sorting is not None:
            self._sorting = self._predict_sorting(upkeep.keep, upkeep.n_keep)
        # for tracker-side metrics (prediction error, NEES): what was predicted for which track,
        # and the observation row it was then updated with (-1: coasted)
        self.last_prediction_ids = self._ids
        self.last_prediction_detection = _observation_rows(det_of_track, rows)
        estimate = self._estimate_mean(self._state)
        if upkeep.n_young and self._prior.learning:
            self._prior.learn(estimate, self._last, upkeep.young, self._spec.dt)
        born = upkeep.unused
        if association.may_start is not None:
            born = born[association.may_start[born]]
        self._initiate(
            z[born], rows[born], upkeep.keep, upkeep.n_keep, self.last_prediction_detection, estimate
        )
        return self._report()

    def _associate_frame(
        self, prediction: Gaussian, predicted: NDArray[np.float64], z: NDArray[np.float64]
    ) -> Association:
        """The associator's association of this frame, given the frame's read-only context."""
        assert self._spec is not None
        frame = FrameContext(
            prediction=prediction,
            predicted=predicted,
            z=z,
            gate=self._gate,
            p_gate=self.p_gate,
            recovery_inflation=self.recovery_inflation,
            noise=self._noise,
            noise_scale=self.noise_scale,
            streak=self._streak,
            last=self._last,
            motion=self._prior.motion_per_frame(self._spec.dt),
            region=self._region,
            spec=self._spec,
        )
        return self.associator.associate(frame)

    def _update_tracks(self, state: Any, association: Association, seen: NDArray[np.bool_]) -> Any:
        """The predicted ``state`` corrected by the associator with this frame's association."""
        return self.associator.update(self.predictor, state, association, seen)

    def _follow_observation_rows(self, obs: Mapping[str, NDArray]) -> None:
        """An observation with more rows than ``max_detections`` (an env that grew its rows for a
        frame with more detections) makes them this tracker's ``max_detections``."""
        assert self._spec is not None
        if not isinstance(obs, Mapping):
            return  # check_observation names what is wrong
        shape = np.shape(obs.get("detections", ()))
        if len(shape) == 2 and shape[0] > self._spec.max_detections:
            self._spec = replace(self._spec, max_detections=int(shape[0]))

    def _grow_report_rows(self, n: int) -> None:
        """More live tracks than ``max_tracks``: the report (and its sorting channel) grows from
        now on — doubled until the ``n`` tracks fit (an env with ``overflow="grow"`` follows the
        report's rows), or to ``n`` rows inside ``track run``'s
        [`growable_reports`][track_envs.contracts.report.growable_reports] —, warned once per episode; never
        inside [`fixed_reports`][track_envs.contracts.report.fixed_reports] (the report then raises)."""
        assert self._spec is not None
        growth = report_growth()
        if growth == "fixed":  # pack_report raises ReportOverflowError, as a fixed report must
            return
        rows = self._spec.max_tracks
        if growth == "exact":
            rows = n
        else:
            while rows < n:
                rows *= 2
            if not self._grew:
                warnings.warn(
                    f"{n} live tracks exceed the report's max_tracks={self._spec.max_tracks}; the report "
                    f"grows to {rows} rows (pass max_tracks >= {n} to the env, or delete tracks sooner)",
                    RuntimeWarning,
                    stacklevel=3,
                )
        self._grew = True
        n = rows
        self._spec = replace(self._spec, max_tracks=n)
        if self._no_sorting is not None:
            self._no_sorting = empty_sorting(n)
        if self._sorting is not None:
            grown = empty_sorting(n)
            for key, value in self._sorting.items():
                grown[key][: len(value)] = value
            self._sorting = grown

    def _report(self) -> dict[str, NDArray]:
        """The report of the live tracks, with the sorting channel when the sensor has a nozzle bar."""
        assert self._spec is not None
        if len(self._ids) > self._spec.max_tracks:
            self._grow_report_rows(len(self._ids))
        report = pack_report(self._ids, self._last, self._detection_rows, self._spec.max_tracks)
        self._frame += 1
        if self._sorting is not None:
            report.update(
                {k: v.copy() for k, v in self._sorting.items()}
                if self._sorting is self._no_sorting
                else self._sorting
            )
        return report

    def _rollout_steps(self) -> int:
        """Frames a deleted track is rolled forward at most: six times what the flow (the velocity
        prior's speed) takes from the region's end to the nozzle bar, plus 10, in ``[20, MAX_STEPS]``
        (all ``MAX_STEPS`` while there is no prior). A track slower than that is no particle on
        the belt (clutter, a stalled estimate) and gets no prediction; rolling it forward for
        ``MAX_STEPS`` frames would cost a learned predictor as many network steps."""
        assert self._spec is not None and self._spec.sorting_line is not None
        if self._prior.mean is None or self._prior.speed <= 0:
            return MAX_STEPS
        reach = self._spec.sorting_line - self._spec.region_high[0]
        steps = int(np.ceil(6.0 * reach / (self._prior.speed * self._spec.dt))) + 10
        return int(np.clip(steps, 20, MAX_STEPS))

    def _predict_sorting(self, keep: NDArray[np.bool_], n_keep: int) -> dict[str, NDArray] | None:
        """The sorting channel of this frame: the predicted crossings of the tracks deleted now."""
        assert self._spec is not None and self._spec.sorting_line is not None
        if n_keep == len(keep):
            return self._no_sorting
        gone = ~keep
        crossings = predict_crossings(
            self.predictor,
            self._state.take(gone),
            self._spec.sorting_line,
            self._frame,
            self._spec.dt,
            self._rollout_steps(),
        )
        ok = crossings.ok
        return pack_sorting(self._ids[gone][ok], crossings.mean[ok], crossings.cov[ok], self._spec.max_tracks)

    def _estimate_mean(self, state: Any) -> NDArray[np.float64]:
        """The predictor's current estimates (n, D) as C-contiguous float64 (its ``estimate_mean``
        when it declares ``MEAN_ONLY_ESTIMATE``, which skips the covariance)."""
        if self._mean_only is not None:
            mean = self._mean_only.estimate_mean(state)
        else:
            mean = self.predictor.estimate(state).mean
        return np.ascontiguousarray(mean, dtype=np.float64)

    def _initiate(
        self,
        z_new: NDArray[np.float64],
        rows_new: NDArray[np.intp],
        keep: NDArray[np.bool_],
        n_keep: int,
        detection_rows: NDArray[np.int64],
        estimate: NDArray[np.float64],
    ) -> None:
        """The kept tracks (``keep``) and new tracks at detections ``z_new`` (k, D), with the
        velocity prior when there is one: states, ids, counters, estimates, detection rows."""
        k = len(z_new)
        self._state = self._start_states(z_new, keep, n_keep)
        if k == 0 and n_keep == len(keep):  # nobody born, nobody deleted
            self._last, self._detection_rows = estimate, detection_rows
            return
        tracks = _kernels.survivors_and_births(
            keep,
            n_keep,
            self._ids,
            self._misses,
            self._streak,
            estimate,
            detection_rows,
            np.ascontiguousarray(z_new, dtype=np.float64),
            np.asarray(rows_new, dtype=np.int64),
            self._next_id,
        )
        self._ids, self._misses, self._streak = tracks.ids, tracks.misses, tracks.streak
        self._last, self._detection_rows = tracks.estimate, tracks.detection_rows
        self._next_id += k

    def _start_states(self, z_new: NDArray[np.float64], keep: NDArray[np.bool_], n_keep: int) -> Any:
        """The predictor state of the kept tracks followed by new tracks started at ``z_new``."""
        k = len(z_new)
        state = self._state
        prior = self._with_prior is not None and self.velocity_prior is not None
        velocity, velocity_cov = (
            (self._prior.mean, self._prior.birth_cov)
            if prior and self._prior.mean is not None
            else (None, None)
        )
        if state is not None and self._fused is not None:
            if k or n_keep < len(keep):
                state = self._fused.survivors_and_births(state, keep, n_keep, z_new, velocity, velocity_cov)
        elif k:
            if n_keep < len(keep):
                state = state.take(keep)
            if velocity is not None and self._with_prior is not None:
                born = self._with_prior.start(
                    z_new,
                    velocity=np.broadcast_to(velocity, z_new.shape),
                    velocity_cov=None
                    if velocity_cov is None
                    else np.broadcast_to(velocity_cov, (k, *velocity_cov.shape)),
                )
            else:
                born = self.predictor.start(z_new)
            state = born if state is None or n_keep == 0 else type(born).concat([state, born])
        elif n_keep < len(keep):
            state = state.take(keep)
        return state


def _observation_rows(det_index: NDArray[np.int64], rows: NDArray[np.intp]) -> NDArray[np.int64]:
    """Observation rows of detection indices (-1 stays -1), safe when there are no detections."""
    row_of = np.empty(len(rows) + 1, dtype=np.int64)
    row_of[:-1] = rows
    row_of[-1] = -1  # what index -1 picks
    return row_of[det_index]
