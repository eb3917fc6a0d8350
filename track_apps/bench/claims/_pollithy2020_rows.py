"""The records of the ``pollithy2020`` suite as the paper's figures read them: the contestants of
Figs. 6 and 7, the belts, the row of each (figure, predictor, setting), and a claim of the table.

Shared by the claims tables ([`pollithy2020`][track_apps.bench.claims.pollithy2020]) and their prose
([`_pollithy2020_text`][track_apps.bench.claims._pollithy2020_text]).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from track_apps.bench.rows import Row

NAME = "pollithy2020"
ENV = "BeltSorter-v0"
NOISE = (0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4)
KINDS = ("cylinder", "sphere", "cuboid")
#: Table I of the paper: mean aleatoric area (mm²) of the NLL-LSTM per added noise std (mm).
PAPER_TABLE1 = {0.0: 0.1743, 0.1: 0.1843, 0.2: 0.2157, 0.3: 0.3073, 0.4: 0.5130, 0.5: 1.0424}
#: Fig. 6 contestants: label → (predictor, agent kwargs).
FIG6 = (
    ("kf-cv", "kf-cv", ()),
    ("kf-cv, q tuned", "kf-cv", (("q", 0.032),)),
    ("kf-ca", "kf-ca", ()),
    ("kf-ca, q tuned", "kf-ca", (("q", 3.2),)),
    ("lstm", "lstm", ()),
    ("nll-lstm", "nll-lstm", ()),
    *((f"mc-lstm T={t}", "mc-lstm", (("samples", t),)) for t in (10, 100, 250, 1000)),
)
#: Fig. 7 contestants: label → (predictor, agent kwargs besides predict_sorting).
FIG7 = (
    ("kf-cv", "kf-cv", ()),
    ("kf-ca", "kf-ca", ()),
    ("lstm (line-searched s·I)", "lstm", ()),
    ("nll-lstm", "nll-lstm", ()),
    ("mc-lstm T=250", "mc-lstm", (("samples", 250),)),
)


#: Env kwargs that give room for dense frames without changing the scene (left out when matching).
ROOM = frozenset({"steps", "max_detections", "max_tracks", "max_targets"})


def _env(row: Row) -> dict[str, Any]:
    return {k: v for k, v in row.setting if k not in ROOM}


def _agent(row: Row) -> tuple[tuple[str, Any], ...]:
    return tuple(sorted((k.removeprefix("agent."), v) for k, v in row.agent_params))


def find(rows: Sequence[Row], agent: str, predictor: str, agent_kwargs: Any = (), **env: Any) -> Row | None:
    """The row of ``agent``/``predictor`` with exactly these agent kwargs and env kwargs."""
    want = tuple(sorted(agent_kwargs))
    for r in rows:
        same = r.env_id == ENV and r.agent == agent and r.predictor == predictor
        if same and _agent(r) == want and _env(r) == env:
            return r
    return None


def fig6_row(rows: Sequence[Row], predictor: str, kwargs: Any, kind: str) -> Row | None:
    return find(rows, "one-step", predictor, kwargs, merge_touching=False, noise_std=1e-4, particle_kind=kind)


#: The belts of Fig. 7: figure key → (env kwargs besides the noise, description, short name).
VARIANTS: dict[str, tuple[dict[str, Any], str, str]] = {
    "fig7": ({}, "default belt: touching particles seen as one blob", "default belt"),
    "fig7_separate": (
        {"merge_touching": False},
        "every particle sensed on its own (merge_touching=False)",
        "separate particles",
    ),
    "fig7_dense": (
        {"merge_touching": False, "feed_rate": 390.0},
        "twice the load, 390 particles/s, every particle sensed on its own",
        "separate particles, twice the load",
    ),
}


def fig7_row(rows: Sequence[Row], predictor: str, kwargs: Any, noise: float, variant: str) -> Row | None:
    env: dict[str, Any] = {"noise_std": noise, **VARIANTS[variant][0]}
    return find(rows, "gnn", predictor, (("predict_sorting", False), *kwargs), **env)


def table1_row(rows: Sequence[Row], noise: float) -> Row | None:
    row = find(
        rows, "one-step", "nll-lstm", (), merge_touching=False, particle_kind="cylinder", noise_std=noise
    )
    return row


def noise_series(values: np.ndarray) -> str:
    """``0 mm 0.0875, 0.5 mm 0.1029``: the finite values by noise level."""
    return ", ".join(
        f"{n * 1e3:g} mm {v:.4f}" for n, v in zip(NOISE, values, strict=True) if math.isfinite(v)
    )


def in_mm(v: float) -> str:
    return "–" if math.isnan(v) else f"{v * 1e3:.3f}"


def track_error_median(row: Row | None) -> float:
    """The median track error of a Fig. 6 row (NaN without the row)."""
    return math.nan if row is None else row.mean.get("track_error_p50", math.nan)


#: e_mean below this at a noise level counts as "no association errors" (a tie, not a win).
NO_ERRORS = 1e-3


@dataclass(frozen=True)
class Claim:
    """One row of the claims table."""

    claim: str
    paper: str
    figure: str
    ours: str
    verdict: str
    note: str
