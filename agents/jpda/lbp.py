r"""Approximate JPDA marginals by loopy belief propagation (Williams, Lau: Approximate evaluation
of marginal association probabilities with belief propagation, 2014).

For one cluster with track weights ``w_ij`` (pairs) and ``w_i∅`` (missed) of
[`agents.jpda.weights`][agents.jpda.weights], let ``ψ_ij = w_ij / w_i∅``. Messages from tracks to detections
``μ_ij`` and back ``ν_ji`` (start ``ν = 1``) iterate

.. math::

    μ_{ij} = \frac{ψ_{ij}}{1 + \sum_{j' \ne j} ψ_{ij'} ν_{j'i}}, \qquad
    ν_{ji} = \frac{1}{1 + \sum_{i' \ne i} μ_{i'j}},

which Williams and Lau show converges; the beliefs are then

.. math::

    β_{ij} = \frac{ψ_{ij} ν_{ji}}{1 + \sum_{j'} ψ_{ij'} ν_{j'i}}, \quad
    β_{i∅} = \frac{1}{1 + \sum_{j'} ψ_{ij'} ν_{j'i}}, \quad
    β_{∅j} = \frac{1}{1 + \sum_{i} μ_{ij}} \ (\text{detection } j \text{ is clutter}).

Each track row sums to 1 exactly; a detection's clutter belief and its track beliefs need not sum
to 1 (they come from different factors). All of it is in log space; the leave-one-out sums
``Σ_{j' ≠ j}`` come from prefix and suffix log-sum-exp (no subtraction, no cancellation).
``w_i∅ = 0`` (``p_D P_G = 1``) is floored at ``e^{-700}`` times the track's largest weight.

Measured error against the exact marginals ([`agents.jpda.exact`][agents.jpda.exact]) on random clusters is
pinned in ``tests/agents/jpda/test_lbp.py``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: log of the floor of ``w_i∅`` relative to the largest weight of track ``i``.
MISS_FLOOR = -700.0


def _leave_one_out(x: FloatArray, axis: int) -> FloatArray:
    """``log(1 + Σ_{k ≠ j} e^{x_k})`` along ``axis`` for every ``j``, from prefix and suffix sums."""
    x = np.moveaxis(x, axis, -1)
    pad = np.full((*x.shape[:-1], 1), -np.inf)
    pre = np.logaddexp.accumulate(np.concatenate([pad, x[..., :-1]], axis=-1), axis=-1)
    suf = np.logaddexp.accumulate(np.concatenate([pad, x[..., :0:-1]], axis=-1), axis=-1)[..., ::-1]
    return np.moveaxis(np.logaddexp(np.logaddexp(pre, suf), 0.0), -1, axis)


def lbp_marginals(
    log_pair: FloatArray, log_miss: FloatArray, tol: float = 1e-10, max_iter: int = 2_000
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Approximate ``β_ij`` (n, m), ``β_i∅`` (n,) and ``β_∅j`` (m,) of one cluster.

    Args:
        log_pair: (n, m) ``log w_ij`` (``-inf`` outside the gate).
        log_miss: (n,) ``log w_i∅``.
        tol: stop when no ``log ν`` changes by more than this.
        max_iter: at most this many sweeps.
    """
    top = np.max(log_pair, axis=1, initial=-np.inf)
    log_miss = np.maximum(log_miss, np.where(np.isfinite(top), top, 0.0) + MISS_FLOOR)
    log_psi = log_pair - log_miss[:, None]
    log_nu = np.zeros_like(log_psi.T)
    for _ in range(max_iter):
        log_mu = log_psi - _leave_one_out(log_psi + log_nu.T, axis=1)
        new = -_leave_one_out(log_mu.T, axis=1)
        new = np.where(np.isfinite(log_psi.T), new, 0.0)
        done = bool(np.all(np.abs(new - log_nu) <= tol))
        log_nu = new
        if done:
            break
    log_mu = log_psi - _leave_one_out(log_psi + log_nu.T, axis=1)
    scores = log_psi + log_nu.T
    norm = np.logaddexp(np.logaddexp.reduce(scores, axis=1, initial=-np.inf), 0.0)
    pairs = np.exp(scores - norm[:, None])
    miss = np.exp(-norm)
    clutter = np.exp(-np.logaddexp(np.logaddexp.reduce(log_mu, axis=0, initial=-np.inf), 0.0))
    return pairs, miss, clutter
