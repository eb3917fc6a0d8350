"""Policies for GateTuning-v0 with stable-baselines3's ``predict``: the trained PPO actor in
numpy (shipped as a model file), and fixed settings.

A PPO ``MlpPolicy`` acts deterministically with the mean of its Gaussian: the actor MLP
``h_{l+1} = tanh(W_l h_l + b_l)`` over the observation, then ``μ = W_a h_L + b_a``, clipped to
the action box. [`export_policy`][track_apps.tuning.policy.export_policy] stores those weights (and
``log_std``) in the project's model-file format
([`predictors.training.model_file`][predictors.training.model_file], kind
[`KIND`][track_apps.tuning.policy.KIND]); [`TunedPolicy`][track_apps.tuning.TunedPolicy] rebuilds the same
function in numpy, so acting needs neither torch nor stable-baselines3.

A policy's core is SB3's ``predict`` ([`Policy`][track_apps.tuning.policy.Policy]: a stable-baselines3 model
is one); what it offers beyond it is declared as every plug-in's capabilities are
([`track_envs.infra.declared`][track_envs.infra.declared]), in its class attribute ``capabilities`` and asked
with [`policy_capability`][track_apps.tuning.policy.policy_capability]:

* ``KNOB_RANGES`` ([`KnobRanges`][track_apps.tuning.policy.KnobRanges]) — ``knobs``: the knobs (and ranges)
its actions are for,
  which must be the env's ([`track_apps.tuning.evaluate.episode_errors`][track_apps.tuning.episode_errors]
  checks). The tuned, fixed and NIS-rule policies.
* ``BINDS_ENV`` ([`BindsEnv`][track_apps.tuning.policy.BindsEnv]) — ``bind(env)``: it plays looking at the env
it is bound to
  (the reference policies, [`SettingChooser`][track_apps.tuning.policy.SettingChooser]); evaluation binds it
  first.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from enum import StrEnum
from importlib import resources
from pathlib import Path
from typing import Any, Literal, Protocol, Self, overload

import numpy as np
from numpy.typing import NDArray

from agents.tracking.knobs import LIVE_KNOBS
from predictors.training.model_file import ModelFile, ModelFileError, load_model, require_shapes, save_model
from track_apps.tuning.knobs import DEFAULT_RANGES, Knob, knob_ranges, make_knobs
from track_envs.infra.declared import Declarations

#: Model-file kind of an exported gate-tuning policy.
KIND = "gate-tuning-ppo"
#: Name of the shipped policy under ``track_apps/tuning/weights``.
SHIPPED = "gate-tuning-ppo"


class Policy(Protocol):
    """The core of a GateTuning-v0 policy: stable-baselines3's ``predict``."""

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], Any]:
        """The action for ``observation`` (and SB3's recurrent state, ``None`` here)."""
        ...


class PolicyCapability(StrEnum):
    """The optional capabilities a policy class may declare (module docstring)."""

    KNOB_RANGES = "knob-ranges"
    BINDS_ENV = "binds-env"


class KnobRanges(Policy, Protocol):
    """``KNOB_RANGES``: the knobs the policy's actions are for."""

    knobs: tuple[Knob, ...]


class BindsEnv(Policy, Protocol):
    """``BINDS_ENV``: plays looking at the env it is bound to."""

    def bind(self, env: Any) -> Any:
        """Play against ``env`` from now on."""
        ...


#: The capabilities of policies ([`track_envs.infra.declared`][track_envs.infra.declared]).
POLICY_DECLARATIONS: Declarations[PolicyCapability] = Declarations(
    PolicyCapability,
    {PolicyCapability.KNOB_RANGES: KnobRanges, PolicyCapability.BINDS_ENV: BindsEnv},
    core=Policy,
)


@overload
def policy_capability(policy: object, which: Literal[PolicyCapability.KNOB_RANGES]) -> KnobRanges | None: ...
@overload
def policy_capability(policy: object, which: Literal[PolicyCapability.BINDS_ENV]) -> BindsEnv | None: ...
def policy_capability(policy: object, which: PolicyCapability) -> Any:
    """``policy``, typed as the protocol of ``which``, when its class declares it; else ``None``."""
    return POLICY_DECLARATIONS.get(policy, which)


def shipped_policy_path() -> Path:
    """The shipped policy's model-file name (without suffix)."""
    return Path(str(resources.files("track_apps.tuning") / "weights" / SHIPPED))


class TunedPolicy:
    """The PPO actor as a numpy MLP with SB3's ``predict`` (module docstring).

    Args:
        model: A model file of kind `KIND`.
    """

    capabilities = frozenset({PolicyCapability.KNOB_RANGES})

    def __init__(self, model: ModelFile):
        if model.kind != KIND:
            raise ModelFileError(f"{model.path or 'model'} holds a {model.kind!r} model; expected {KIND!r}")
        arch = model.architecture
        self.obs_dim, self.act_dim = int(arch["obs_dim"]), int(arch["act_dim"])
        hidden = [int(h) for h in arch["hidden"]]
        if arch.get("activation", "tanh") != "tanh":
            raise ModelFileError(f"{model.path}: activation {arch['activation']!r}; this loader runs tanh")
        sizes = [self.obs_dim, *hidden]
        shapes: dict[str, tuple[int, ...]] = {
            f"pi.{i}.weight": (sizes[i + 1], sizes[i]) for i in range(len(hidden))
        }
        shapes |= {f"pi.{i}.bias": (sizes[i + 1],) for i in range(len(hidden))}
        shapes |= {
            "action.weight": (self.act_dim, sizes[-1]),
            "action.bias": (self.act_dim,),
            "log_std": (self.act_dim,),
        }
        require_shapes(model, shapes)
        t = model.tensors
        self._layers = [
            (np.asarray(t[f"pi.{i}.weight"], np.float64), np.asarray(t[f"pi.{i}.bias"], np.float64))
            for i in range(len(hidden))
        ]
        self._head = (np.asarray(t["action.weight"], np.float64), np.asarray(t["action.bias"], np.float64))
        self.log_std = np.asarray(t["log_std"], np.float64)
        self.model = model
        self.knobs = make_knobs(arch.get("ranges", DEFAULT_RANGES))
        self.env_kwargs: dict[str, Any] = dict(model.meta.get("env_kwargs", {}))

    def mean_action(self, obs: NDArray[np.floating]) -> NDArray[np.float64]:
        """The actor's mean ``μ(obs)`` (before clipping), for (obs_dim,) or (n, obs_dim)."""
        h = np.asarray(obs, dtype=np.float64)
        for w, b in self._layers:
            h = np.tanh(h @ w.T + b)
        w, b = self._head
        return h @ w.T + b

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
        rng: np.random.Generator | None = None,
    ) -> tuple[NDArray[np.float32], None]:
        """SB3's ``predict``: the action for one observation (obs_dim,) or a batch (n, obs_dim).

        ``deterministic=True`` gives the mean action; ``False`` samples ``μ + σ ε`` with the
        learnt ``σ = exp(log_std)`` from ``rng`` (default: a fresh generator). Actions are clipped
        to [-1, 1] as SB3 clips them.

        Raises:
            ValueError: for an observation of another width.
        """
        obs = np.asarray(observation, dtype=np.float64)
        if obs.shape[-1:] != (self.obs_dim,) or obs.ndim not in (1, 2):
            raise ValueError(
                f"observation must have shape ({self.obs_dim},) or (n, {self.obs_dim}), got {obs.shape}"
            )
        mu = self.mean_action(obs)
        if not deterministic:
            rng = rng if rng is not None else np.random.default_rng()
            mu = mu + np.exp(self.log_std) * rng.standard_normal(mu.shape)
        return np.clip(mu, -1.0, 1.0).astype(np.float32), None


class FixedPolicy:
    """A constant setting of the knobs, with SB3's ``predict`` (the fixed baselines).

    Args:
        values: ``{knob: value}`` for some knobs; the others stay at ``defaults``.
        defaults: Values of the knobs not given (default: the gnn's defaults).
        ranges: The env's knob ranges (default `DEFAULT_RANGES`).
    """

    GNN_DEFAULTS: Mapping[str, float] = {name: knob.default for name, knob in LIVE_KNOBS.items()}
    capabilities = frozenset({PolicyCapability.KNOB_RANGES})

    def __init__(
        self,
        values: Mapping[str, float] | None = None,
        defaults: Mapping[str, float] | None = None,
        ranges: Mapping[str, Any] | None = None,
    ):
        self.knobs = make_knobs(ranges)
        names = [k.name for k in self.knobs]
        given = dict(values or {})
        unknown = sorted(set(given) - set(names))
        if unknown:
            raise ValueError(f"unknown knob {unknown}; the knobs are {names}")
        self.values = {**dict(defaults or self.GNN_DEFAULTS), **given}
        self.action = np.array([k.action(self.values[k.name]) for k in self.knobs], dtype=np.float32)

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """The constant action (batched like ``observation``)."""
        obs = np.asarray(observation)
        return (np.broadcast_to(self.action, (*obs.shape[:-1], len(self.action))).copy(), None)


class SettingChooser:
    """A reference policy that, bound to the env it plays, picks one of several fixed settings at
    every step ([`choose`][track_apps.tuning.policy.SettingChooser.choose], given the bound env): the
    lookahead oracle and the sensor-informed reference. ``choices`` records the picks of the episode.

    Args:
        settings: Knob settings to choose from; knobs a setting omits keep the env's initial values.

    Call [`bind`][track_apps.tuning.policy.SettingChooser.bind] with the env being played before the first
    [`predict`][track_apps.tuning.policy.SettingChooser.predict];
    [`track_apps.tuning.evaluate.evaluate`][track_apps.tuning.evaluate.evaluate] does so.
    """

    capabilities = frozenset({PolicyCapability.BINDS_ENV})

    def __init__(self, settings: Sequence[Mapping[str, float]]):
        self.settings = [dict(s) for s in settings]
        if not self.settings:
            raise ValueError(f"{type(self).__name__} needs at least one setting to choose from")
        self._env: Any = None
        self._actions: list[NDArray[np.float32]] = []
        self.choices: list[int] = []

    def bind(self, env: Any) -> Self:
        """Play against ``env`` (a [`GateTuningEnv`][track_apps.tuning.env.GateTuningEnv]); returns self."""
        env = env.unwrapped
        initial = {k.name: k.value(float(a)) for k, a in zip(env.knobs, env.initial_action, strict=True)}
        ranges = knob_ranges(env.knobs)
        actions = [FixedPolicy(c, defaults=initial, ranges=ranges).action for c in self.settings]
        self._env, self._actions, self.choices = env, actions, []
        return self

    def choose(self, env: Any) -> int:
        """Index of the setting to play next on the bound ``env``."""
        raise NotImplementedError

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """The action of the setting [`choose`][track_apps.tuning.policy.SettingChooser.choose] picks.

        Raises:
            RuntimeError: before [`bind`][track_apps.tuning.policy.SettingChooser.bind].
        """
        if self._env is None:
            raise RuntimeError(f"{type(self).__name__}.predict before bind(env): bind it to the env it plays")
        best = self.choose(self._env)
        self.choices.append(best)
        return self._actions[best].copy(), None


def export_policy(
    model: Any,
    path: str | os.PathLike[str],
    *,
    ranges: Mapping[str, Any] | None = None,
    meta: Mapping[str, Any] | None = None,
) -> ModelFile:
    """Write the actor of an SB3 PPO ``MlpPolicy`` (tanh, shared-nothing actor) as a model file.

    Raises:
        ValueError: for a policy that is not a plain tanh MLP actor with a Gaussian head.
    """
    import torch

    policy = model.policy
    net = policy.mlp_extractor.policy_net
    linears = [m for m in net if isinstance(m, torch.nn.Linear)]
    acts = [m for m in net if not isinstance(m, torch.nn.Linear)]
    if not all(isinstance(a, torch.nn.Tanh) for a in acts) or len(acts) != len(linears):
        raise ValueError("export_policy needs an actor of Linear + Tanh layers (SB3's default MlpPolicy)")
    if getattr(policy.features_extractor_class, "__name__", "") != "FlattenExtractor":
        raise ValueError("export_policy needs the FlattenExtractor (a Box observation)")
    tensors: dict[str, NDArray[np.float32]] = {}
    for i, layer in enumerate(linears):
        tensors[f"pi.{i}.weight"] = layer.weight.detach().cpu().numpy()
        tensors[f"pi.{i}.bias"] = layer.bias.detach().cpu().numpy()
    tensors["action.weight"] = policy.action_net.weight.detach().cpu().numpy()
    tensors["action.bias"] = policy.action_net.bias.detach().cpu().numpy()
    tensors["log_std"] = policy.log_std.detach().cpu().numpy()
    knobs = make_knobs(ranges)
    file = ModelFile(
        kind=KIND,
        dim=2,
        architecture={
            "obs_dim": int(policy.observation_space.shape[0]),
            "act_dim": int(policy.action_space.shape[0]),
            "hidden": [int(layer.out_features) for layer in linears],
            "activation": "tanh",
            "knobs": [k.name for k in knobs],
            "ranges": {k.name: [k.low, k.high] for k in knobs},
        },
        tensors=tensors,
        meta=dict(meta or {}),
    )
    save_model(path, file)
    return load_model(path, kind=KIND)


def load_policy(path: str | os.PathLike[str] | None = None) -> TunedPolicy:
    """The gate-tuning policy at ``path`` (default: the one shipped with the package), as an
    object with SB3's ``predict(obs, deterministic=True)``; numpy only.

    Raises:
        ModelFileError: naming the file and what is wrong (missing, another kind, shapes).
    """
    return TunedPolicy(load_model(shipped_policy_path() if path is None else path, kind=KIND))
