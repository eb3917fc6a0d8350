"""The episode loop: one agent tracks one episode of one env.

[`run_episode`][agents.run_episode] is the loop the benchmark cells, the ``lstm`` line search of
``track train`` and the examples share::

    from agents import make_agent, run_episode
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=200))
    result = run_episode(env, make_agent("gnn", predictor="kf-ca"), seed=0)
    result.metrics["e_mean"], result.frames

Per frame it calls ``agent.act(obs)`` and steps the env with the report. It resets the env with
``seed`` and the agent with the env's sensor spec and the same seed. An
oracle (``AgentTraits(needs_truth=True)``, declaring ``TRUTH_OBSERVER``:
[`agents.base.TruthObserver`][agents.base.TruthObserver]) gets each frame's ``info``
through ``observe_truth(info)`` before ``act``, and its own ``episode_metrics()`` join the
result's. A tracker never sees ``info``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym

from agents.base import AgentCapability, agent_capability, agent_traits

#: ``on_step(frame, obs, report, reward, info)``: called after each env step with the frame index
#: (0 for the first), the observation the agent answered, its report, and the step's reward and
#: ``info``.
OnStep = Callable[[int, Mapping[str, Any], Mapping[str, Any], float, Mapping[str, Any]], None]


@dataclass(frozen=True)
class EpisodeResult:
    """What [`run_episode`][agents.run_episode] did.

    Attributes:
        metrics: The episode metrics: the ``info["episode_metrics"]`` of an env wrapped in
            [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics] (its ``episode_metrics()`` so far when
            ``steps`` ended the loop first), then a truth observer's own ``episode_metrics()``;
            empty for an env without that wrapper.
        frames: Env steps taken.
        terminated: Whether the last step terminated the episode.
        truncated: Whether the last step truncated it (e.g. ``max_episode_steps``).
        info: The last step's ``info``.
    """

    metrics: dict[str, float]
    frames: int
    terminated: bool
    truncated: bool
    info: Mapping[str, Any] = field(repr=False)


def run_episode(
    env: gym.Env,
    agent: Any,
    *,
    seed: int | None,
    steps: int | None = None,
    on_step: OnStep | None = None,
) -> EpisodeResult:
    """Run ``agent`` on one episode of ``env`` until it ends or after ``steps`` frames.

    Args:
        env: A tracking env, usually wrapped in [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics].
        agent: An [`Agent`][agents.Agent]; a truth observer (``needs_truth``,
            ``TRUTH_OBSERVER``) gets each
            frame's ``info`` before ``act``.
        seed: Seed of ``env.reset`` and ``agent.reset``.
        steps: Stop after this many frames (``None``: when the env terminates or truncates).
        on_step: Called after every env step (`OnStep`).

    Returns:
        The [`EpisodeResult`][agents.EpisodeResult].

    Raises:
        ValueError: ``steps`` below 1.
    """
    if steps is not None and steps < 1:
        raise ValueError(f"steps must be >= 1 or None, got {steps}")
    obs, info = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    oracle = (
        agent_capability(agent, AgentCapability.TRUTH_OBSERVER) if agent_traits(agent).needs_truth else None
    )
    if agent_traits(agent).needs_truth and oracle is None:
        raise ValueError(
            f"{type(agent).__name__} declares needs_truth but not AgentCapability.TRUTH_OBSERVER "
            "(observe_truth(info), episode_metrics()): declare it in its capabilities"
        )
    observe = None if oracle is None else oracle.observe_truth
    frames = 0
    while True:
        if observe is not None:
            observe(info)
        report = agent.act(obs)
        seen = obs
        obs, reward, terminated, truncated, info = env.step(report)
        if on_step is not None:
            on_step(frames, seen, report, float(reward), info)
        frames += 1
        if terminated or truncated or (steps is not None and frames >= steps):
            break
    metrics = _episode_metrics(env, info)
    if oracle is not None:
        metrics.update(oracle.episode_metrics())
    return EpisodeResult(metrics, frames, bool(terminated), bool(truncated), info)


def _episode_metrics(env: gym.Env, info: Mapping[str, Any]) -> dict[str, float]:
    """The last step's ``episode_metrics``, or the metrics wrapper's so far, or none."""
    if "episode_metrics" in info:
        return dict(info["episode_metrics"])
    try:
        so_far = env.get_wrapper_attr("episode_metrics")
    except AttributeError:
        return {}
    return dict(so_far())
