"""Rows: the records of a bench run aggregated per contestant and setting, and what every table,
figure and claim check built on them shares (their labels, writing a figure).

A [`Row`][track_apps.bench.rows.Row] is one (env, params, agent, predictor) with mean ± std over the seeds
(sample std, 0 for a single seed; NaN values, e.g. an occlusion error without occlusion, are left out). The
params are everything else that changes a cell's result
([`track_apps.bench.cells.Cell.params`][track_apps.bench.Cell.params]):
the env kwargs, ``steps``, ``episodes`` (shown when not 1) and the agent kwargs (``agent.NAME``),
so records made with other steps, episodes or kwargs in the same out dir are separate rows,
never pooled.

[`track_apps.bench.tables`][track_apps.bench.tables] (tables and plots),
[`track_apps.bench.figures`][track_apps.bench.figures] (the predictor-score plots) and
[`track_apps.bench.claims`][track_apps.bench.claims] (paper reproductions) import from here and not from each
other's private names.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from track_apps.bench.cells import Cell
from track_envs.infra import atomic


def params_text(params: Sequence[tuple[str, Any]]) -> str:
    """``"noise_std=0.0001, steps=100"`` (``"-"`` for none)."""
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in params) or "-"


@dataclass(frozen=True)
class Row:
    """Aggregate of the records of one (env, params, agent, predictor).

    ``params`` is [`Cell.params`][track_apps.bench.Cell.params]: env kwargs, steps,
    episodes, and agent kwargs as ``agent.NAME``.
    """

    env_id: str
    params: tuple[tuple[str, Any], ...]
    agent: str
    predictor: str
    n: int
    mean: dict[str, float]
    std: dict[str, float]

    @property
    def params_label(self) -> str:
        return params_text(self.params)

    @property
    def setting(self) -> tuple[tuple[str, Any], ...]:
        """The params of the env and the episode budget (what the agents compete on)."""
        return tuple((k, v) for k, v in self.params if not k.startswith("agent."))

    @property
    def agent_params(self) -> tuple[tuple[str, Any], ...]:
        """The agent kwargs, as ``(agent.NAME, value)`` pairs."""
        return tuple((k, v) for k, v in self.params if k.startswith("agent."))


def _stats(values: Sequence[float]) -> tuple[float, float]:
    finite = [v for v in values if not math.isnan(v)]
    if not finite:
        return math.nan, math.nan
    return float(np.mean(finite)), float(np.std(finite, ddof=1)) if len(finite) > 1 else 0.0


def aggregate(records: Sequence[dict[str, Any]]) -> list[Row]:
    """Rows of mean ± std over seeds, sorted by env, params, agent, predictor."""
    groups: dict[tuple[Any, ...], list[dict[str, float]]] = defaultdict(list)
    for rec in records:
        cell = Cell.from_dict(rec["cell"])
        groups[(cell.env_id, cell.params(), cell.agent, cell.predictor)].append(rec["metrics"])
    rows = []
    for (env_id, params, agent, predictor), metrics in groups.items():
        keys = list(dict.fromkeys(k for m in metrics for k in m))
        stats = {k: _stats([float(m.get(k, math.nan)) for m in metrics]) for k in keys}
        mean = {k: s[0] for k, s in stats.items()}
        std = {k: s[1] for k, s in stats.items()}
        rows.append(Row(env_id, params, agent, predictor, len(metrics), mean, std))
    return sorted(rows, key=lambda r: (r.env_id, repr(r.params), r.agent, r.predictor))


def row_label(row: Row) -> str:
    """Legend and tick label of a row's contestant: agent, predictor and agent kwargs."""
    name = row.agent if row.predictor == "-" else f"{row.agent}/{row.predictor}"
    extra = params_text([(k.removeprefix("agent."), v) for k, v in row.agent_params])
    return name if not row.agent_params else f"{name} ({extra})"


def save_figure(fig: Any, path: Path) -> Path:
    """Lay out, write as PNG (100 dpi) and close a matplotlib figure; its path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    try:
        atomic.save_figure(fig, path, dpi=100)
    finally:
        plt.close(fig)
    return path
