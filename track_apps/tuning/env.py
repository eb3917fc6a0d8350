"""GateTuning-v0: the association knobs of a GNN tracker as the action of a Gymnasium env."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

import track_envs  # noqa: F401  (registers the base envs)
from agents.base import AgentCapability, agent_capability
from agents.gnn.agent import GnnAgent
from track_apps.bench.cells import env_kwarg_names
from track_apps.tuning.diagnostics import FEATURE_BOUND, FEATURES, N_FEATURES, WindowDiagnostics
from track_apps.tuning.knobs import check_action, make_knobs
from track_envs.infra.arguments import check_int
from track_envs.metrics.belt import AssociationErrors

#: Report rows of the base env unless ``base_kwargs`` sets ``max_tracks``: with clutter and a tight
#: gate the belt's tracks outnumber BeltSorter-v0's default 256 rows (and the tracker stops).
BASE_MAX_TRACKS = 512
#: Truth rows of a base env that takes ``max_targets`` (BeltSorter-v0) unless ``base_kwargs`` sets
#: it: a busy belt holds more than the default 256 particles at times, and particles beyond the
#: truth rows would escape the association errors (the reward).
BASE_MAX_TARGETS = 512
#: Reward kinds: minus the window's new association errors, or minus its summed GOSPA.
REWARDS = ("errors", "gospa")
#: Episodes started without a seed draw their base env's seed below this; evaluation seeds lie
#: at and above it, so they are never trained on.
HELD_OUT_SEEDS = 1_000_000_000


def association_error_count(metric: AssociationErrors) -> int:
    """``#tracks holding measurements of > 1 particle + #particles whose measurements went to
    ≠ 1 track`` so far: the numerators of e1 and e2 ([`track_envs.metrics.belt`][track_envs.metrics.belt])."""
    r = metric.compute()
    return round(r["e1"] * r["n_tracks"]) + round(r["e2"] * r["n_particles"])


class GateTuningEnv(gym.Env[NDArray[np.float32], NDArray[np.float32]]):
    """Tune a running GNN tracker's association knobs while the sensor drifts.

    ## Description
    Each step runs ``frames_per_step`` (K) frames of a point env (``base_env``, default
    BeltSorter-v0 with the ``"belt"`` drift of [`track_envs.envs.drift`][track_envs.envs.drift]: noise std,
    detection probability and clutter rate drift over the episode while ``sensor_spec`` stays nominal)
    tracked by a [`GnnAgent`][agents.gnn.agent.GnnAgent]; before the K frames the action sets the
    tracker's knobs. A policy sees only what the tracker can compute itself and must keep the
    gates right as the sensor changes under it.

    ## Action
    ``Box(-1, 1, (3,), float32)``: ``p_gate``, ``recovery_inflation`` and ``noise_scale`` (the
    factor on the declared noise std the predictor assumes), each mapped to a log-scaled range
    ([`track_apps.tuning.knobs`][track_apps.tuning.knobs]; defaults: ``1 − p_gate`` in 1e-6 … 0.5, inflation 1
    … 1000, noise scale 0.25 … 64). An action of another shape, or outside [-1, 1], raises ``ValueError``.

    ## Observation
    ``Box(-5, 5, (12,), float32)``: the tracker diagnostics of the last K frames
    ([`track_apps.tuning.diagnostics`][track_apps.tuning.diagnostics]: NIS statistics of the assigned pairs,
    fraction of detections left unassigned, births, deletions, coasting fraction, track count, detections per
    track), then the knobs in effect during them as normalised actions. No truth: a real tracker
    computes the same. ``reset`` returns zero diagnostics and the initial knobs.

    ## Reward
    ``reward="errors"`` (default): minus the association errors that arose in the window, i.e.
    the increase of ``E = #tracks holding measurements of more than one particle + #particles
    whose measurements went to ≠ 1 track`` — the numerators of e1 and e2 (Pfaff et al. 2017;
    Pollithy et al. 2020), streamed over the episode. An episode's return is minus its ``E``, so
    maximising the return minimises the errors e1/e2 count. (The errors are what the gates
    decide; GOSPA is dominated by the measurement noise, which no knob changes.) ``"gospa"``:
    the base env's reward summed over the window (minus the per-frame GOSPA).

    ## Starting State
    The base env reset with the seed (``reset(seed=s)`` gives the base episode of seed ``s``, as
    ``track bench`` runs it), a new tracker with the initial knobs (``agent_kwargs`` or the
    gnn defaults, clipped to the ranges). Resets without a seed draw the base seed from the
    env's generator, below [`HELD_OUT_SEEDS`][track_apps.tuning.env.HELD_OUT_SEEDS].

    ## Episode End
    Truncated after ``episode_steps`` steps (default 100, i.e. 1,000 frames); terminated when the
    base env terminates.

    ## Info
    ``knobs`` (the values set), ``association_errors`` (``E`` so far), ``frames``, and the base
    env's ``sensor`` of the window's last frame (the true drifted values; truth side).

    ## Arguments
    - ``base_env``: a point env id (default ``"BeltSorter-v0"``); ``base_kwargs``: its kwargs
      (``max_tracks`` defaults to [`BASE_MAX_TRACKS`][track_apps.tuning.env.BASE_MAX_TRACKS] = 512, and
      ``max_targets``, where the env takes it, to
      [`BASE_MAX_TARGETS`][track_apps.tuning.env.BASE_MAX_TARGETS] = 512).
    - ``drift``: the base env's drift (default ``"belt"``, the drift the shipped policy was
      trained for); None: no drift.
    - ``predictor``: the gnn's predictor (default ``"kf-ca"``; ``noise_scale`` needs a Kalman
      filter); ``agent_kwargs``: further gnn kwargs (the knobs given here are the initial values).
    - ``frames_per_step``: K (default 10); ``episode_steps`` (default 100).
    - ``ranges``: ``{knob: (low, high)}`` overriding the default ranges.
    - ``reward``: ``"errors"`` or ``"gospa"``.
    - ``render_mode``: ``"rgb_array"`` (the base env's frame with the tracks) or None.

    ## Version History
    - v0: the first version. Its streams (which also pin the GNN tracker it
      runs) changed once under v0 before the digests pinned them, and are pinned since 2026-12-02: on
      2026-12-02 the action's ranges were widened to contain the best fixed setting (``p_gate``
      from 0.5, noise scale up to 64), so the zero action is another setting, and the
      BeltSorter-v0 base env got 512 truth rows. Added without changing them: 512 report rows for
      the base env (2026-12-01).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012

    def __init__(
        self,
        *,
        base_env: str = "BeltSorter-v0",
        drift: Any = "belt",
        base_kwargs: Mapping[str, Any] | None = None,
        predictor: str = "kf-ca",
        agent_kwargs: Mapping[str, Any] | None = None,
        frames_per_step: int = 10,
        episode_steps: int = 100,
        ranges: Mapping[str, Sequence[float]] | None = None,
        reward: str = "errors",
        render_mode: str | None = None,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
        self.render_mode = render_mode
        if reward not in REWARDS:
            raise ValueError(f"reward must be one of {list(REWARDS)}, got {reward!r}")
        self.reward_kind = reward
        self.frames_per_step = check_int("frames_per_step", frames_per_step, 1)
        self.episode_steps = check_int("episode_steps", episode_steps, 1)
        self.knobs = make_knobs(ranges)
        kwargs = dict(base_kwargs or {})
        kwargs.setdefault("max_tracks", BASE_MAX_TRACKS)
        if "max_targets" in (env_kwarg_names(base_env) or ()):
            kwargs.setdefault("max_targets", BASE_MAX_TARGETS)
        if render_mode is not None:
            kwargs["render_mode"] = render_mode
        if drift is not None:
            kwargs["drift"] = drift
        try:
            self.base = gym.make(base_env, disable_env_checker=True, **kwargs)
        except TypeError as exc:
            raise ValueError(f"base_env {base_env!r} cannot be built with {sorted(kwargs)}: {exc}") from None
        self.base_env_id = base_env
        spec = self.base.unwrapped.sensor_spec  # type: ignore[attr-defined]
        if tuple(self.base.unwrapped.position_shape) != (spec.dim,):  # type: ignore[attr-defined]
            raise ValueError(f"base_env must be a point env, {base_env!r} has poses")
        agent_kwargs = dict(agent_kwargs or {})
        agent_kwargs.setdefault("predict_sorting", False)  # no valve here: skip the roll-outs
        self.agent = GnnAgent(predictor=predictor, **agent_kwargs)
        # the knobs are the gnn tracker's documented settable attributes (its live knobs,
        # agents.tracking.knobs); its predictions (asked after each reset, which starts them) feed
        # the diagnostics
        self._knobbed = self.agent
        self._predictions: Any = None
        self.initial_action = np.array(
            [k.action(getattr(self._knobbed, k.name)) for k in self.knobs], dtype=np.float32
        )
        self._diagnostics = WindowDiagnostics(spec.dim)
        n = N_FEATURES + len(self.knobs)
        self.observation_space = spaces.Box(-FEATURE_BOUND, FEATURE_BOUND, shape=(n,), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(len(self.knobs),), dtype=np.float32)
        self.feature_names = (*FEATURES, *(f"knob_{k.name}" for k in self.knobs))
        self._obs: dict[str, NDArray] | None = None
        self._info: dict[str, Any] = {}

    # -- gymnasium API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        super().reset(seed=seed)
        base_seed = int(seed) if seed is not None else int(self.np_random.integers(HELD_OUT_SEEDS))
        self._obs, self._info = self.base.reset(seed=base_seed)
        self.agent.reset(self.base.unwrapped.sensor_spec, seed=base_seed)  # type: ignore[attr-defined]
        self._predictions = _declared(self.agent, AgentCapability.LAST_PREDICTION)
        self._metric = AssociationErrors()
        self._errors = 0
        self._steps = 0
        self._frames = 0
        self._apply(self.initial_action.astype(np.float64))
        self._diagnostics.clear()
        return self._observation(self.initial_action), self._step_info()

    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        if self._obs is None:
            raise RuntimeError("step() called before reset(); call env.reset(seed=...) first")
        a = check_action(action, len(self.knobs))
        self._apply(a)
        self._diagnostics.clear()
        gospa = 0.0
        terminated = truncated = False
        agent, diag, predictions = self.agent, self._diagnostics, self._predictions
        for _ in range(self.frames_per_step):
            obs, info = self._obs, self._info
            ids_before = agent._ids
            had_tracks = len(ids_before) > 0
            report = agent.act(obs)
            last = predictions.last_prediction
            prediction = (last.mean, last.cov) if had_tracks and last is not None else None
            rows = predictions.last_prediction_detection if had_tracks else None
            diag.add_frame(obs, ids_before, report, prediction, rows)
            ids = info.get("detection_ids_merged", info["detection_ids"])
            self._metric.update(info["truth"], ids, report)
            self._obs, base_reward, terminated, truncated, self._info = self.base.step(report)
            gospa += float(base_reward)
            self._frames += 1
            if terminated or truncated:
                break
        self._steps += 1
        errors = association_error_count(self._metric)
        reward = float(self._errors - errors) if self.reward_kind == "errors" else gospa
        self._errors = errors
        truncated = truncated or self._steps >= self.episode_steps
        return self._observation(a), reward, bool(terminated), bool(truncated), self._step_info()

    # -- helpers ------------------------------------------------------------------------------
    def _apply(self, a: NDArray[np.float64]) -> None:
        for knob, value in zip(self.knobs, a, strict=True):
            setattr(self._knobbed, knob.name, knob.value(float(value)))

    def knob_values(self) -> dict[str, float]:
        """The knobs' current values on the tracker."""
        return {k.name: float(getattr(self._knobbed, k.name)) for k in self.knobs}

    def true_sensor(self) -> dict[str, float] | None:
        """The base env's true sensor values of the last frame played (``info["sensor"]``: truth
        side, for references such as [`SensorInformedPolicy`][track_apps.tuning.SensorInformedPolicy]), or
        None when the base env reports none (no drift)."""
        sensor = self._info.get("sensor")
        return None if sensor is None else {k: float(v) for k, v in dict(sensor).items()}

    def _observation(self, a: NDArray[Any]) -> NDArray[np.float32]:
        return np.concatenate([self._diagnostics.vector(), np.asarray(a, dtype=np.float32)])

    def _step_info(self) -> dict[str, Any]:
        info: dict[str, Any] = {
            "knobs": self.knob_values(),
            "association_errors": self._errors,
            "frames": self._frames,
        }
        if "sensor" in self._info:
            info["sensor"] = dict(self._info["sensor"])
        return info

    def render(self) -> NDArray[np.uint8] | None:
        """The base env's frame of the window's last frame (``render_mode="rgb_array"``)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to gym.make")
            return None
        return self.base.render()  # type: ignore[return-value]

    def close(self) -> None:
        self.base.close()


def _declared(agent: GnnAgent, which: AgentCapability) -> Any:
    """``agent`` as capability ``which`` (the tracker GateTuning-v0 drives must declare it)."""
    declared = agent_capability(agent, which)
    if declared is None:
        raise TypeError(
            f"GateTuning-v0 needs a tracker that declares {which.name}; {type(agent).__name__} does not"
        )
    return declared
