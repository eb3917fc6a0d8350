"""Global nearest neighbour (GNN) multi-target tracker (the tracker of Pollithy et al. 2020).

Every frame, for the ``n`` live tracks and the ``m`` detections of the observation:

1. **predict**: ``predictor.predict`` gives each track's predicted measurement ``N(ŷ_i, S_i)``;
2. **gate and associate**: squared Mahalanobis costs, χ² gate at ``p_gate``, Hungarian (or greedy)
   assignment with a per-track miss cost (:mod:`agents.tracking.assign`);
   Tracks and detections left over get a second chance with every predicted covariance scaled by
   ``recovery_inflation``, so that a particle kicked out of its gate by a collision keeps its track.
   The second chance is capped in distance: a leftover track may only take a detection within

   .. math::

       r = k_u \\, u + k_σ \\, σ, \\qquad u = \\max(\\lVert \\bar v \\rVert \\, dt,\\;
           \\operatorname{median}_i \\lVert ŷ_i - x̂_i \\rVert)

   of its prediction, where ``u`` is the stream's motion per frame (the speed of the velocity
   prior ``v̄``, or the median predicted displacement of the live tracks when larger), ``σ`` the
   sensor's noise std and ``k_u = recovery_cap_motion``, ``k_σ = recovery_cap_noise``: an inflated
   gate of a coasting track grows with every miss, and without the cap it reaches far past the
   particles next to it.
   With clutter declared (``SensorSpec.clutter_rate > 0``, density ``λ`` = rate / region volume)
   and misses (``p_D = SensorSpec.p_detect < 1``), a leftover track has either not been detected
   or been detected outside its gate, with odds ``(1 − p_D) : (p_D − a)``, where ``a`` is the rate
   at which established tracks (updated the last two frames, predicted inside the region) find a
   detection in their gate (measured over the last ≈100 frames; ``p_D − a`` at least
   ``p_D (1 − p_gate)``). The second chance then takes a pair only when the kicked-target
   hypothesis beats a miss plus a clutter detection,
   ``(p_D − a) N(z; ŷ, f S) ≥ (1 − p_D) λ`` (:func:`agents.gnn._kernels.clutter_log_odds`):
   on a stream whose motion model holds (``a ≈ p_D``) a coasting track no longer takes the clutter
   detection or another target's first detection in its inflated gate, while on a belt whose
   collisions knock particles out of their gates (``a < p_D``) it still recovers them. Without
   clutter, or with ``p_D = 1``, the second chance is as above;
3. **update / coast**: assigned tracks are corrected with their detection, the others coast;
4. **delete**: tracks with more than ``max_misses`` consecutive misses, and tracks that were not
   updated and whose predicted measurement has left the observed region (grown by ``region_margin``);
5. **initiate**: a new track from every detection left unassigned. Its velocity prior is learnt
   online (``velocity_prior="auto"``): every frame, each young track (updated 3–6 times in a row)
   gives one sample, its frame-to-frame velocity; the last ``FLOW_WINDOW`` samples, over as many
   frames as it takes to collect them, give the prior's median ``v̄`` and robust variance
   ``(1.4826 MAD)²`` (re-estimated with every new sample while there are few, every
   ``FLOW_WINDOW / 8`` samples once the window is full). On a belt this is the flow where
   particles enter, so a track's second measurement is predicted where the flow takes it. The
   prior forms from ``MIN_FLOW_SAMPLES`` samples, i.e. from the first track that was updated a
   few times, so a sparse stream (one particle at a time) has it as early as a dense one. Until
   then new tracks start from ``velocity_fallback`` when given (e.g. the belt speed), else from
   the predictor's default. :attr:`GnnAgent.velocity_prior_state` shows the prior.

The report holds every live track at its current (posterior) estimate, and the detection row it
was updated with (−1 when it coasted). When the sensor has a nozzle bar downstream
(``SensorSpec.sorting_line``, BeltSorter-v0), every track deleted in a frame gets a predicted
crossing of the bar in the report's sorting channel (:mod:`track_envs.sorting_channel`): its
predictor rolled forward from the track's state without further measurements
(:func:`agents.tracking.sorting.predict_crossings`; a track slower than a sixth of the flow is given
up, see :meth:`GnnAgent._rollout_steps`). A deleted track has coasted since its last update,
and coasting is that roll-out, so the prediction is the one from the last update.

All per-frame work is batched over tracks and detections: with the Kalman predictors, the filter
steps, the start states, the gated costs, the second-chance costs and the per-track bookkeeping
are each one compiled loop (numba: :mod:`predictors.kalman._kernels`,
:mod:`agents.tracking._kernels`, :mod:`agents.gnn._kernels`), so a frame is a few dozen
calls whatever the number of tracks. The kernels compile (or load from numba's cache) on first
use; :meth:`GnnAgent.warm_up` runs every one of them once on a tiny synthetic input, so that a
live stream does not pause on its first frames.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import AgentCapability, AgentTraits
from agents.gnn import _kernels
from agents.gnn.knobs import NOISE_SCALE, P_GATE, RECOVERY_INFLATION
from agents.tracking.assign import ASSIGNERS, ASSOCIATORS, chi2_gate
from agents.tracking.merges import share_blobs
from agents.tracking.sorting import MAX_STEPS, predict_crossings
from predictors.base import Capability, Predictor, capability, reset_predictor
from predictors.registry import resolve_predictor
from track_envs.observation import check_observation
from track_envs.report import pack_report
from track_envs.sorting_channel import empty_sorting, pack_sorting
from track_envs.types import Gaussian, SensorSpec

#: Update streaks (consecutive updates) of the young tracks the velocity prior is learnt from.
YOUNG_STREAK = (3, 6)
#: Velocity samples (one per young track and frame) the learnt prior is taken over, newest first.
FLOW_WINDOW = 128
#: Fewest samples for the learnt prior to be used.
MIN_FLOW_SAMPLES = 3
#: With clutter, the gate's hit rate (the second chance's clutter test) is measured on the tracks
#: updated in each of the last ``HIT_STREAK`` frames, ...
HIT_STREAK = 2
#: ... over sums that forget this factor per frame (a memory of ≈100 frames), ...
HIT_MEMORY = 0.99
#: ... starting from this many track-frames at the declared rate ``p_D P_G``.
HIT_PRIOR = 50.0


@dataclass(frozen=True)
class VelocityPriorState:
    """The velocity prior new tracks start from (read-only copy).

    Attributes:
        mean: (D,) prior velocity ``v̄``, or None when new tracks start from the predictor's default.
        variance: (D,) robust variance of the samples per axis (before the widening applied at a
            track's start), or None.
        n_samples: Velocity samples in the learnt estimate (0 when not learning).
        source: ``"learnt"``, ``"fallback"`` (``velocity_fallback`` until enough samples),
            ``"fixed"`` (a given ``velocity_prior``) or ``"none"``.
    """

    mean: NDArray[np.float64] | None
    variance: NDArray[np.float64] | None
    n_samples: int
    source: str


class GnnAgent:
    """GNN multi-target tracker: χ² gate, Hungarian, pluggable predictor (Pollithy et al. 2020).

    Args:
        predictor: Registered predictor name (``"kf-ca"``, ``"kf-cv"``, ``"random-walk"``, ...) or an
            object implementing the Predictor protocol (its methods are checked here).
        p_gate: Gate probability of the χ² gate (Pollithy et al. 2020: 0.999).
        assignment: ``"hungarian"`` (optimal) or ``"greedy"``.
        max_misses: A track is deleted after more than this many consecutive misses.
        region_margin: Tracks are deleted when their prediction leaves the observed region grown
            by this much (sensor units) on every side; ``math.inf`` turns this deletion off (tracks
            are then deleted after ``max_misses`` misses only).
        velocity_prior: ``"auto"`` (learnt online, see the module docstring), ``None`` (the
            predictor's own default) or a fixed velocity (D,).
        recovery_inflation: Covariance scale of the second-chance association of leftover tracks
            and detections (1 turns it off).
        velocity_fallback: With ``velocity_prior="auto"``, the velocity (D,) new tracks start from
            until the prior is learnt (e.g. the belt speed); None: the predictor's default.
        recovery_cap_motion: ``k_u``, the second-chance jump cap in multiples of the stream's
            motion per frame (see the module docstring), >= 0. The default 3 lets a track that
            coasted a few frames behind or ahead of its particle (a new track whose first velocity
            was off, a kick) take it back, and keeps it from jumping tens of millimetres onto
            another particle (at 1 m/s and 200 Hz: 15 mm).
        recovery_cap_noise: ``k_σ``, the cap's allowance in multiples of the sensor noise std, >= 0.
        blob_extent: Merged blobs (:mod:`agents.tracking.merges`): a track left without a detection whose
            prediction lies within this distance (sensor units) of a detection another track took,
            itself predicted within it, shares that detection; the blob's tracks are updated as a
            rigid group, each keeping its predicted offset. 0 (the default) turns sharing off.
        noise_scale: Factor ``k`` on the sensor's declared noise std that the predictor assumes
            (``R = (k σ)² I``) and that the second-chance cap uses, > 0 (default 1). Needs a
            predictor that declares the ``NOISE_SCALE`` capability (``set_noise_scale``: the Kalman
            filters) unless it is 1.
        predict_sorting: With a nozzle bar in the sensor spec, report each deleted track's
            predicted crossing (the sorting channel; default True). ``False`` skips the
            roll-outs (a learned predictor steps its network once per roll-out frame) and reports
            no sorting channel, for throughput when no valve is driven.
        **predictor_kwargs: Passed to ``make_predictor`` when ``predictor`` is a name; a keyword
            that neither the agent nor that predictor takes raises
            :class:`~track_envs.registry.UnknownArgumentError` listing the arguments of both.

    Live knobs: :attr:`p_gate`, :attr:`recovery_inflation` and :attr:`noise_scale` may be set
    between frames of a running episode (each is checked, and the next frame uses it); this is
    how GateTuning-v0 (:mod:`agents.tuning`) acts on the tracker.
    """

    capabilities = frozenset(  # agents.base.AgentCapability
        {
            AgentCapability.WARM_UP,
            AgentCapability.TRACK_COVARIANCES,
            AgentCapability.LAST_PREDICTION,
            AgentCapability.LIVE_KNOBS,
            AgentCapability.SELF_CALIBRATION,
        }
    )
    traits = AgentTraits(takes_predictor=True)
    #: Built with ``predictor=`` (a Gaussian predictor's name or object).
    takes_predictor = True

    def __init__(
        self,
        predictor: str | Predictor = "kf-ca",
        *,
        p_gate: float = P_GATE.default,
        assignment: str = "hungarian",
        max_misses: int = 2,
        region_margin: float = 0.0,
        velocity_prior: str | NDArray | None = "auto",
        recovery_inflation: float = RECOVERY_INFLATION.default,
        velocity_fallback: NDArray | None = None,
        recovery_cap_motion: float = 3.0,
        recovery_cap_noise: float = 5.0,
        blob_extent: float = 0.0,
        noise_scale: float = NOISE_SCALE.default,
        predict_sorting: bool = True,
        **predictor_kwargs: Any,
    ):
        # the arguments as given, for the throwaway copy of warm_up()
        self._init_kwargs: dict[str, Any] = {
            "predictor": predictor,
            "p_gate": p_gate,
            "assignment": assignment,
            "max_misses": max_misses,
            "region_margin": region_margin,
            "velocity_prior": velocity_prior,
            "recovery_inflation": recovery_inflation,
            "velocity_fallback": velocity_fallback,
            "recovery_cap_motion": recovery_cap_motion,
            "recovery_cap_noise": recovery_cap_noise,
            "blob_extent": blob_extent,
            "noise_scale": noise_scale,
            "predict_sorting": predict_sorting,
            **predictor_kwargs,
        }
        if not isinstance(predict_sorting, bool | np.bool_):
            raise ValueError(f"predict_sorting must be True or False, got {predict_sorting!r}")
        self.predict_sorting = bool(predict_sorting)
        if assignment not in ASSOCIATORS:
            raise ValueError(f"assignment must be one of {sorted(ASSOCIATORS)}, got {assignment!r}")
        if not (isinstance(max_misses, int) and max_misses >= 0):
            raise ValueError(f"max_misses must be an integer >= 0, got {max_misses!r}")
        if isinstance(region_margin, bool) or not (
            isinstance(region_margin, int | float | np.integer | np.floating) and region_margin >= 0
        ):
            raise ValueError(
                f"region_margin must be a number >= 0 (inf: no region deletion), got {region_margin!r}"
            )
        if isinstance(velocity_prior, str) and velocity_prior != "auto":
            raise ValueError(
                f"velocity_prior must be 'auto', None or a velocity vector, got {velocity_prior!r}"
            )
        self.predictor: Predictor = resolve_predictor(predictor, owner=type(self), **predictor_kwargs)
        # the optional capabilities of the predictor this tracker uses (predictors.base), or None
        self._scalable = capability(self.predictor, Capability.NOISE_SCALE)
        self._with_prior = capability(self.predictor, Capability.VELOCITY_PRIOR)
        self._mean_only = capability(self.predictor, Capability.MEAN_ONLY_ESTIMATE)
        self._fused = capability(self.predictor, Capability.FUSED_SURVIVORS_BIRTHS)
        self.predictor_name = predictor if isinstance(predictor, str) else type(predictor).__name__
        self._spec: SensorSpec | None = None
        self.p_gate = p_gate
        self.assignment = assignment
        self._associate = ASSOCIATORS[assignment]
        self._assign = ASSIGNERS[assignment]
        self.max_misses = max_misses
        self.region_margin = region_margin
        self.velocity_prior = velocity_prior
        self.recovery_inflation = recovery_inflation
        self.noise_scale = noise_scale
        for name, value in (
            ("recovery_cap_motion", recovery_cap_motion),
            ("recovery_cap_noise", recovery_cap_noise),
        ):
            if not (isinstance(value, int | float) and np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        self.recovery_cap_motion = float(recovery_cap_motion)
        self.recovery_cap_noise = float(recovery_cap_noise)
        if not (isinstance(blob_extent, int | float) and np.isfinite(blob_extent) and blob_extent >= 0):
            raise ValueError(f"blob_extent must be a finite distance >= 0, got {blob_extent!r}")
        self.blob_extent = float(blob_extent)
        self.velocity_fallback = (
            None if velocity_fallback is None else np.asarray(velocity_fallback, np.float64)
        )

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
        self._flow_mean: NDArray | None = None
        self._flow_var: NDArray | None = None
        self._flow_speed = 0.0
        self._birth_cov: NDArray | None = None
        self._learning = isinstance(self.velocity_prior, str)
        self._flow_samples = np.zeros((FLOW_WINDOW, spec.dim))
        self._n_flow_samples = 0
        self._flow_head = 0
        self._flow_fresh = 0
        if self.velocity_prior is not None and not isinstance(self.velocity_prior, str):
            v = np.asarray(self.velocity_prior, dtype=np.float64)
            if v.shape != (spec.dim,):
                raise ValueError(f"velocity_prior must have shape ({spec.dim},), got {v.shape}")
            self._set_flow(v, None)
        elif self._learning and self.velocity_fallback is not None:
            if self.velocity_fallback.shape != (spec.dim,) or not np.all(np.isfinite(self.velocity_fallback)):
                raise ValueError(
                    f"velocity_fallback must be a finite vector of shape ({spec.dim},), "
                    f"got {self.velocity_fallback.tolist()}"
                )
            self._set_flow(self.velocity_fallback.copy(), None)
        # λ, the declared clutter density (detections per unit volume of the region and frame)
        self._clutter_density = float(spec.clutter_rate) / float(np.prod(spec.region_size))
        self._gate_hits = 0.0  # forgetting sums of the gate's hit rate (_gate_hit_rate)
        self._gate_tries = 0.0
        # the cap's noise std, with the predictors' floor R >= (1 µm)²
        self._noise = max(float(spec.noise_std) * self.noise_scale, 1e-6)
        lo = np.asarray(spec.region_low, dtype=np.float64) - self.region_margin
        hi = np.asarray(spec.region_high, dtype=np.float64) + self.region_margin
        self._region = (lo, hi)
        self.last_prediction: Gaussian | None = None
        self.last_prediction_ids = np.zeros(0, dtype=np.int64)
        self.last_prediction_detection = np.zeros(0, dtype=np.int64)
        self._frame = 0
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
        if not self._learning:
            source = "none" if self._flow_mean is None else "fixed"
        elif self._n_flow_samples >= MIN_FLOW_SAMPLES:
            source = "learnt"
        else:
            source = "none" if self._flow_mean is None else "fallback"
        return VelocityPriorState(
            mean=None if self._flow_mean is None else self._flow_mean.copy(),
            variance=None if self._flow_var is None else self._flow_var.copy(),
            n_samples=self._n_flow_samples,
            source=source,
        )

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel a frame can use, on a tiny synthetic stream.

        The first frames of a new process that start, associate or recover tracks otherwise pause
        for tens of milliseconds while the kernels load — frames a live sorter would drop. Call
        this once before the stream starts; it runs a throwaway copy of this tracker (same
        arguments, a copy of the predictor) and leaves this one untouched.
        """
        import copy

        kwargs = dict(self._init_kwargs)
        if not isinstance(kwargs["predictor"], str):
            kwargs["predictor"] = copy.deepcopy(kwargs["predictor"])
        twin = type(self)(**kwargs)
        dim = self._spec.dim if self._spec is not None else 2
        spec, frames = _warm_up_stream(dim, sorting=self.predict_sorting)
        twin.reset(spec)
        for obs in frames:
            twin.act(obs)

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
            self._initiate(z, rows, np.zeros(0, dtype=np.bool_), 0, np.zeros(0, dtype=np.int64), self._last)
            self._sorting = self._no_sorting
            return self._report()
        self._state, prediction = self.predictor.predict(self._state)
        self.last_prediction = prediction
        predicted = np.ascontiguousarray(prediction.mean, dtype=np.float64)
        det_of_track, z_tracks = self._associate_frame(prediction, predicted, z)
        upkeep = _kernels.frame_upkeep(
            det_of_track,
            self._misses,
            self._streak,
            predicted,
            self._region[0],
            self._region[1],
            self.max_misses,
            YOUNG_STREAK,
            m,
        )
        self._misses, self._streak = upkeep.misses, upkeep.streak
        self._state = self._update_tracks(self._state, z_tracks, upkeep.seen)
        if self._no_sorting is not None:
            self._sorting = self._predict_sorting(upkeep.keep, upkeep.n_keep)
        # for tracker-side metrics (prediction error, NEES): what was predicted for which track,
        # and the observation row it was then updated with (-1: coasted)
        self.last_prediction_ids = self._ids
        self.last_prediction_detection = _observation_rows(det_of_track, rows)
        estimate = self._estimate_mean(self._state)
        if upkeep.n_young and self._learning:
            self._learn_flow(estimate, upkeep.young)
        born = self._births(upkeep.unused)
        self._initiate(
            z[born], rows[born], upkeep.keep, upkeep.n_keep, self.last_prediction_detection, estimate
        )
        return self._report()

    def _associate_frame(
        self, prediction: Gaussian, predicted: NDArray[np.float64], z: NDArray[np.float64]
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The association of one frame: the detection index of every track (−1: none; what the
        bookkeeping counts as seen and what is left for births) and the (n, D) measurement each
        track is updated with (rows of tracks without a detection are never read).

        gnn: :meth:`associate`, then the shared blobs of :mod:`agents.tracking.merges` when
        ``blob_extent > 0``. A tracker with another association overrides this (and
        :meth:`_update_tracks`); everything else of a frame is shared.
        """
        det_of_track = self.associate(prediction, z)
        m = len(z)
        if self.blob_extent > 0 and m:
            return share_blobs(predicted, z, det_of_track, self.blob_extent, *self._region)
        # rows of coasting tracks (detection −1) are never read by the update
        return det_of_track, z[det_of_track] if m else np.zeros_like(predicted)

    def _births(self, unused: NDArray[np.int64]) -> NDArray[np.int64]:
        """The detections that start new tracks, of those no track took (gnn: all of them)."""
        return unused

    def _update_tracks(self, state: Any, z_tracks: NDArray[np.float64], seen: NDArray[np.bool_]) -> Any:
        """Correct the predicted ``state`` with the frame's association (gnn: the predictor's
        ``update`` of the seen tracks by their rows of ``z_tracks``)."""
        return self.predictor.update(state, z_tracks, seen)

    def _report(self) -> dict[str, NDArray]:
        """The report of the live tracks, with the sorting channel when the sensor has a nozzle bar."""
        assert self._spec is not None
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
        if self._flow_mean is None or self._flow_speed <= 0:
            return MAX_STEPS
        reach = self._spec.sorting_line - self._spec.region_high[0]
        steps = int(np.ceil(6.0 * reach / (self._flow_speed * self._spec.dt))) + 10
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

    def associate(self, prediction: Gaussian, z: NDArray[np.float64]) -> NDArray[np.int64]:
        """The detection index of every track this frame (−1: none): gate and assign, then the
        capped second chance of the leftovers (see the module docstring).

        Args:
            prediction: Predicted measurements of the ``n`` live tracks.
            z: (m, D) detections.

        Returns:
            (n,) int64 detection index per track.
        """
        n, m = len(prediction.mean), len(z)
        det_of_track = np.full(n, -1, dtype=np.int64)
        track_rows, det_cols = self._associate(prediction, z, self._gate)
        det_of_track[track_rows] = det_cols
        if len(track_rows) < min(n, m) and self.recovery_inflation > 1.0:
            self._recover(prediction, z, det_of_track)
        return det_of_track

    def _count_gate_hits(self, det_of_track: NDArray[np.int64], predicted: NDArray[np.floating]) -> None:
        """Add this frame's established tracks (updated in each of the last ``HIT_STREAK`` frames,
        predicted inside the observed region: a target that left gives no detection) and those of
        them that found a detection in their gate (``det_of_track`` after the gated assignment) to
        the forgetting sums of :meth:`_gate_hit_rate`. Counted in every frame with a second chance,
        which with clutter is nearly every frame (a clutter detection is left over)."""
        assert self._spec is not None
        inside = np.all(
            (predicted >= np.asarray(self._spec.region_low))
            & (predicted <= np.asarray(self._spec.region_high)),
            axis=1,
        )
        established = (self._streak >= HIT_STREAK) & inside
        tries = int(np.count_nonzero(established))
        hits = int(np.count_nonzero(det_of_track[established] >= 0))
        self._gate_tries = HIT_MEMORY * self._gate_tries + tries
        self._gate_hits = HIT_MEMORY * self._gate_hits + hits

    def _gate_hit_rate(self) -> float:
        """``a``, the probability that a track finds its detection in its gate: the rate of the
        established tracks over the last frames (sums forgetting ``HIT_MEMORY`` per frame), with
        ``HIT_PRIOR`` track-frames at the declared model's ``p_D P_G`` (the rate when the motion
        model holds)."""
        assert self._spec is not None
        declared = self._spec.p_detect * self.p_gate
        return (self._gate_hits + HIT_PRIOR * declared) / (self._gate_tries + HIT_PRIOR)

    def _recover(self, prediction: Gaussian, z: NDArray[np.float64], det_of_track: NDArray[np.int64]) -> None:
        """Second-chance association of the tracks and detections left over, with inflated gates.

        A collision or a kick moves a particle outside its track's gate; before that detection
        starts a new track, the leftovers are matched once more with every predicted covariance
        scaled by ``recovery_inflation``, among the pairs within the distance cap ``r`` of each
        other (module docstring; :func:`agents.gnn._kernels.recovery_costs`), in place on
        ``det_of_track``. Called when there are leftovers on both sides. With clutter declared,
        a pair must also beat a miss plus a clutter detection (the module docstring's clutter
        test, whose hit rate ``a`` this counts from ``det_of_track`` as it comes in).
        """
        assert self._spec is not None
        if self._clutter_density > 0 and len(self._streak) == len(det_of_track):
            self._count_gate_hits(det_of_track, prediction.mean)
        leftovers = _kernels.recovery_costs(
            np.ascontiguousarray(prediction.mean, dtype=np.float64),
            np.ascontiguousarray(prediction.cov, dtype=np.float64),
            z,
            det_of_track,
            self.recovery_inflation,
            self._gate,
            self._last,
            self._flow_speed * self._spec.dt if self._flow_mean is not None else 0.0,
            self.recovery_cap_motion,
            self.recovery_cap_noise * self._noise,
            _kernels.clutter_log_odds(
                self._spec.p_detect, self._clutter_density, self._gate_hit_rate(), self.p_gate, self._spec.dim
            ),
        )
        if leftovers.bad >= 0:
            raise np.linalg.LinAlgError(
                f"predicted covariance S of track {leftovers.bad} is not positive definite"
            )
        if leftovers.n_admissible == 0:
            return
        rows, cols = self._assign(leftovers.cost, self._gate)
        det_of_track[leftovers.tracks[rows]] = leftovers.dets[cols]

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
        prior = self._with_prior is not None and self.velocity_prior is not None
        velocity, velocity_cov = (
            (self._flow_mean, self._birth_cov) if prior and self._flow_mean is not None else (None, None)
        )
        if self._state is not None and self._fused is not None:
            if k or n_keep < len(keep):
                self._state = self._fused.survivors_and_births(
                    self._state, keep, n_keep, z_new, velocity, velocity_cov
                )
        elif k:
            if n_keep < len(keep):
                self._state = self._state.take(keep)
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
            self._state = (
                born if self._state is None or n_keep == 0 else type(born).concat([self._state, born])
            )
        elif n_keep < len(keep):
            self._state = self._state.take(keep)
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

    def _learn_flow(self, estimate: NDArray[np.float64], young: NDArray[np.bool_]) -> None:
        """Add the velocities of the ``young`` tracks (updated 3–6 frames in a row) to the prior's
        samples, and re-estimate the prior once there are ``MIN_FLOW_SAMPLES``.

        New tracks are born where young tracks were born a few frames ago, so the velocities of
        young tracks are the right prior for them (on a belt: the entry speed, not the mean flow).
        """
        assert self._spec is not None
        flow = _kernels.learn_flow(
            self._flow_samples,
            self._n_flow_samples,
            self._flow_head,
            self._flow_fresh,
            estimate,
            self._last,
            young,
            self._spec.dt,
            MIN_FLOW_SAMPLES,
        )
        self._n_flow_samples, self._flow_head, self._flow_fresh = flow.n_samples, flow.head, flow.fresh
        if flow.updated:
            self._set_flow(flow.median, flow.variance)

    def _set_flow(self, mean: NDArray[np.float64], variance: NDArray[np.float64] | None) -> None:
        """Set the velocity prior and what new tracks start from: mean ``v̄`` and, with a spread,
        the covariance ``diag(4 σ² + (0.1 ‖v̄‖)²)`` — the spread of young tracks doubled, with a
        floor of 10% of the flow speed: the prior must admit the particle that deviates, not just
        the typical one."""
        self._flow_mean, self._flow_var = mean, variance
        self._flow_speed = float(np.sqrt(mean @ mean))
        self._birth_cov = (
            None if variance is None else np.diag(4.0 * variance + (0.1 * self._flow_speed) ** 2)
        )


def _warm_up_stream(dim: int, sorting: bool = True) -> tuple[SensorSpec, list[dict[str, NDArray]]]:
    """A few frames that run every path of a frame: births, lone and competing pairs, the
    second chance, coasting, deletions and an empty frame (for :meth:`GnnAgent.warm_up`); with
    ``sorting`` (and ``dim >= 2``) the sensor has a nozzle bar, so that the deletions run the
    sorting roll-out too."""
    dt = 0.01
    spec = SensorSpec(
        dt=dt,
        dim=dim,
        noise_std=1e-4,
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=(0.0,) * dim,
        region_high=(1.0,) * dim,
        max_detections=8,
        max_tracks=16,
        sorting_line=1.05 if sorting and dim >= 2 else None,
    )
    start = np.full((5, dim), 0.1)
    start[:, -1] = [0.1, 0.5, 0.9, 0.3, 0.3003]  # the last two compete for each other's detections
    velocity = np.zeros(dim)
    velocity[0] = 1.0
    frames: list[dict[str, NDArray]] = []
    for t in range(9):
        z = start + t * dt * velocity
        if t == 6:
            z[0, 0] += 0.003  # out of its gate, within the second chance
        if t == 8:
            z = z[:0]
        det = np.zeros((spec.max_detections, dim), np.float32)
        mask = np.zeros(spec.max_detections, np.int8)
        det[: len(z)], mask[: len(z)] = z, 1
        frames.append({"detections": det, "mask": mask})
    frames += [frames[-1]] * (2 + 1)  # coast until deleted, then a frame without tracks
    return spec, frames


def _observation_rows(det_index: NDArray[np.int64], rows: NDArray[np.intp]) -> NDArray[np.int64]:
    """Observation rows of detection indices (-1 stays -1), safe when there are no detections."""
    row_of = np.empty(len(rows) + 1, dtype=np.int64)
    row_of[:-1] = rows
    row_of[-1] = -1  # what index -1 picks
    return row_of[det_index]
