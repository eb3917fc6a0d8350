"""What the point and the pose paths of ``track run`` share ([`track_apps.cli.run`][track_apps.cli.run],
[`track_apps.cli.run_pose`][track_apps.cli.run_pose]): the agent built from ``--agent`` and ``--predictor``,
and the table of the metrics."""

from __future__ import annotations

from typing import Any

from agents.base import agent_takes_predictor, make_agent


def build_agent(name: str, predictor: str | None, kwargs: dict[str, Any]) -> Any:
    """``make_agent(name, predictor=..., **kwargs)`` (``--predictor`` for an agent without one: an error)."""
    takes = agent_takes_predictor(name)
    if predictor is not None and not takes:
        raise ValueError(f"agent {name!r} takes no predictor; drop --predictor")
    if takes:
        kwargs = {"predictor": predictor or "kf-ca"} | kwargs
    return make_agent(name, **kwargs)


def format_metrics(metrics: dict[str, float]) -> str:
    """A two-column table of the metrics."""
    width = max(map(len, metrics), default=6)
    rows = [f"{'metric':<{width}}  value", f"{'-' * width}  {'-' * 12}"]
    rows += [f"{k:<{width}}  {v:.6g}" for k, v in metrics.items()]
    return "\n".join(rows)
