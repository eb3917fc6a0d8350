"""Generalised optimal sub-pattern assignment (GOSPA) between two point sets.

Rahmathullah, García-Fernández, Svensson, "Generalized optimal sub-pattern assignment metric",
FUSION 2017. With cut-off ``c``, order ``p`` and ``α = 2`` the metric of truths ``X`` (m points)
and estimates ``Y`` (n points) is

.. math::

    d_p^{(c,2)}(X, Y) = \\Big( \\min_{\\gamma} \\sum_{(i,j) \\in \\gamma} d(x_i, y_j)^p
        + \\frac{c^p}{2} \\big(|X| + |Y| - 2|\\gamma|\\big) \\Big)^{1/p}

where ``γ`` ranges over partial assignments whose pairs are closer than ``c``. Equivalently (and
how it is computed here) assign ``min(m, n)`` pairs optimally with cost ``min(d, c)^p`` and add
``c^p / 2 · |m − n|``: a pair at ``d ≥ c`` costs ``c^p``, exactly one miss plus one false target.
Track identities play no part, so duplicate ids are distinct hypotheses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.assignment import min_cost_with_misses, pairwise_distances


@dataclass(frozen=True)
class GospaResult:
    """GOSPA of one frame and its decomposition (all to the power ``p``, then the total root).

    Attributes:
        distance: ``d_p^{(c,2)}``, in sensor units.
        localisation: Sum of ``d^p`` over assigned pairs closer than ``c``.
        missed: Number of truths left unassigned (or assigned farther than ``c``).
        false: Number of estimates left unassigned (or assigned farther than ``c``).
    """

    distance: float
    localisation: float
    missed: int
    false: int


def gospa(
    truth: NDArray[np.floating], estimates: NDArray[np.floating], c: float, p: float = 2.0
) -> GospaResult:
    """GOSPA (α = 2) of ``estimates`` (n, D) against ``truth`` (m, D).

    Args:
        truth: True positions, (m, D).
        estimates: Estimated positions, (n, D).
        c: Cut-off distance, > 0.
        p: Order, >= 1.
    """
    if not c > 0:
        raise ValueError(f"GOSPA cut-off c must be > 0, got {c!r}")
    if not p >= 1:
        raise ValueError(f"GOSPA order p must be >= 1, got {p!r}")
    x = np.asarray(truth, dtype=np.float64)
    y = np.asarray(estimates, dtype=np.float64)
    m, n = len(x), len(y)
    cp = c**p
    if m == 0 or n == 0:
        total = cp / 2 * (m + n)
        return GospaResult(total ** (1 / p), 0.0, m, n)
    d = pairwise_distances(x, y)
    cost = d * d if p == 2 else d**p
    # pairs at d >= c cost as much as a miss plus a false target: assign only closer pairs,
    # each worth c^p − d^p (the objective of min_cost_with_misses with gate c^p)
    rows, cols = min_cost_with_misses(cost, cp)
    close = d[rows, cols] < c
    loc = float(cost[rows, cols][close].sum())
    n_pairs = int(close.sum())
    total = loc + cp / 2 * (m + n - 2 * n_pairs)
    return GospaResult(total ** (1 / p), loc, m - n_pairs, n - n_pairs)
