"""PPO on GateTuning-v0 (stable-baselines3): vector envs, progress bar, checkpoints, export.

The trained actor is written in the project's model-file format
([`track_apps.tuning.policy`][track_apps.tuning.policy]) with the command, its wall time, the PPO settings and
the env kwargs in the sidecar; SB3 checkpoints (zips, not shipped) go to ``OUT/checkpoints``. Rewards are
normalised for learning by ``VecNormalize`` (rewards only: the observation the exported actor sees is the
env's own).
"""

from __future__ import annotations

import platform
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from track_envs.infra.atomic import atomic_path

SB3_HINT = 'training needs stable-baselines3: pip install "track-envs[rl]"'


@dataclass(frozen=True)
class TrainConfig:
    """The PPO run (defaults: the shipped policy's)."""

    timesteps: int = 60_000
    n_envs: int = 2
    vec: str = "subproc"  # "subproc" (SubprocVecEnv) or "dummy" (DummyVecEnv)
    seed: int = 0
    n_steps: int = 256  # per env and update
    batch_size: int = 128
    n_epochs: int = 10
    learning_rate: float = 3e-4
    gamma: float = 0.9
    gae_lambda: float = 0.9
    clip_range: float = 0.2
    ent_coef: float = 0.0
    log_std_init: float = -1.0
    hidden: tuple[int, ...] = (64, 64)
    checkpoint_every: int = 10_000  # env steps (all envs together)
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)


def _import_sb3() -> Any:
    try:
        import stable_baselines3
    except ImportError:
        raise ImportError(SB3_HINT) from None
    return stable_baselines3


def make_vec_env(config: TrainConfig) -> Any:
    """The training vector env: ``n_envs`` GateTuning-v0 (seeds ``seed``, ``seed + 1``, ...)."""
    _import_sb3()
    from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    import track_apps.tuning  # noqa: F401  (registers GateTuning-v0 here and in the workers)

    if config.vec not in ("subproc", "dummy"):
        raise ValueError(f"vec must be 'subproc' or 'dummy', got {config.vec!r}")
    vec_cls = SubprocVecEnv if config.vec == "subproc" else DummyVecEnv
    return sb3_make_vec_env(
        "GateTuning-v0",
        n_envs=config.n_envs,
        seed=config.seed,
        vec_env_cls=vec_cls,
        env_kwargs={"render_mode": None, **config.env_kwargs},  # SB3 would ask for rgb_array
    )


def train(
    config: TrainConfig,
    out: str | Path,
    *,
    policy_out: str | Path | None = None,
    progress: bool = True,
    command: str = "",
) -> tuple[Any, dict[str, Any]]:
    """Train PPO; save checkpoints under ``out`` and the actor at ``policy_out`` (default
    ``out/policy``). Returns the SB3 model and the training summary written to the sidecar."""
    _import_sb3()
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import CheckpointCallback
    from stable_baselines3.common.vec_env import VecNormalize

    from track_apps.tuning.policy import export_policy

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(config.seed)
    venv = VecNormalize(make_vec_env(config), norm_obs=False, norm_reward=True, gamma=config.gamma)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=config.n_steps,
        batch_size=config.batch_size,
        n_epochs=config.n_epochs,
        learning_rate=config.learning_rate,
        gamma=config.gamma,
        gae_lambda=config.gae_lambda,
        clip_range=config.clip_range,
        ent_coef=config.ent_coef,
        policy_kwargs={
            "net_arch": {"pi": list(config.hidden), "vf": list(config.hidden)},
            "activation_fn": torch.nn.Tanh,
            "log_std_init": config.log_std_init,
        },
        seed=config.seed,
        device="cpu",
        verbose=0,
    )
    callbacks: list[Any] = []
    if config.checkpoint_every > 0:
        every = max(config.checkpoint_every // config.n_envs, 1)
        callbacks.append(CheckpointCallback(every, str(out / "checkpoints"), name_prefix="ppo"))
    start = time.perf_counter()
    try:
        model.learn(config.timesteps, callback=callbacks or None, progress_bar=progress)
    finally:
        venv.close()
    wall = time.perf_counter() - start
    import stable_baselines3

    summary = {
        "command": command,
        "wall_s": round(wall, 1),
        "timesteps": int(model.num_timesteps),
        "config": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()},
        "host": {"cpus": _cpu_count(), "torch_threads": torch.get_num_threads()},
    }
    versions = {
        "python": platform.python_version(),
        "torch": torch.__version__,
        "stable-baselines3": stable_baselines3.__version__,
        "numpy": np.__version__,
    }
    meta = {"training": summary, "env_kwargs": dict(config.env_kwargs), "versions": versions}
    export_policy(model, policy_out if policy_out is not None else out / "policy", meta=meta)
    with atomic_path(
        out / "ppo_final.zip", keep_suffix=True
    ) as tmp:  # SB3 keeps a name ending in .zip as it is
        model.save(tmp)
    return model, summary


def _cpu_count() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
