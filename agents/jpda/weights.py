r"""JPDA joint-event weights in log space, and the Gaussian innovation likelihoods they use.

A joint association event ``θ`` assigns every track ``i`` either one detection ``j`` inside its
gate or "missed", with no detection taken twice; detections that no track takes are clutter.
With Poisson clutter of spatial density ``λ``, detection probability ``p_D`` and gate probability
``P_G``, the posterior probability of ``θ`` given the detections is (Fortmann, Bar-Shalom,
Scheffe: Sonar tracking of multiple targets using joint probabilistic data association, 1983, in
the parametric form with the gate probability of Bar-Shalom's PDA filter)

.. math::

    P(θ \mid Z) = \frac{1}{c} \prod_{(i, j) \in θ} \frac{p_D\, g_{ij}}{λ}
                  \prod_{i \text{ missed in } θ} (1 - p_D P_G),
    \qquad g_{ij} = \mathcal{N}(z_j;\ \hat y_i,\ S_i),

where ``c`` normalises over all events. Only the ratios matter, so the weights are kept as

.. math::

    \log w_{ij} = \log p_D + \log g_{ij} - \log λ \ \text{(gated pairs, } -∞ \text{ otherwise)},
    \qquad \log w_{i\varnothing} = \log(1 - p_D P_G),

and every product above is a sum of logs: likelihoods of ``e^{-800}`` or ``e^{+800}`` neither
underflow nor overflow. This is the weight Stone Soup's ``PDAHypothesiser`` gives to each
single-track hypothesis and its ``JPDA`` multiplies into joint events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.tracking.assign import mahalanobis_cost
from track_envs.values.types import Gaussian

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class EventWeights:
    """Log weights of the factors of a joint event.

    Attributes:
        log_pair: (n_tracks, n_detections) ``log w_ij``; ``-inf`` for pairs outside the gate.
        log_miss: (n_tracks,) ``log w_i∅``; ``-inf`` when ``p_D P_G = 1`` (a track is never missed).
    """

    log_pair: FloatArray
    log_miss: FloatArray


def _probability(name: str, value: float) -> float:
    v = float(value)
    if not 0.0 < v <= 1.0:
        raise ValueError(f"{name} must be in (0, 1], got {value!r}")
    return v


def jpda_log_weights(
    log_likelihood: NDArray[np.floating],
    gate: NDArray[np.bool_],
    p_detect: float,
    clutter_density: float,
    p_gate: float = 1.0,
) -> EventWeights:
    """The log weights ``log w_ij`` and ``log w_i∅`` of the module docstring.

    Args:
        log_likelihood: (n_tracks, n_detections) ``log g_ij``, the Gaussian innovation
            log-density; ``-inf`` allowed, NaN and ``+inf`` not (also outside the gate).
        gate: (n_tracks, n_detections) boolean, the admissible pairs.
        p_detect: ``p_D`` in (0, 1].
        clutter_density: ``λ > 0``, expected clutter detections per unit measurement volume.
        p_gate: ``P_G`` in (0, 1], the probability that a detected target falls inside its gate.

    Raises:
        ValueError: naming the offending argument and value.
    """
    pd = _probability("p_detect", p_detect)
    pg = _probability("p_gate", p_gate)
    lam = float(clutter_density)
    if not (lam > 0.0 and math.isfinite(lam)):
        raise ValueError(f"clutter_density must be a finite number > 0, got {clutter_density!r}")
    ll = np.asarray(log_likelihood, dtype=np.float64)
    g = np.asarray(gate)
    if ll.ndim != 2:
        raise ValueError(f"log_likelihood must be (n_tracks, n_detections), got shape {ll.shape}")
    if g.shape != ll.shape:
        raise ValueError(f"gate must have the shape of log_likelihood {ll.shape}, got {g.shape}")
    if g.dtype != np.bool_:
        raise ValueError(f"gate must be boolean, got dtype {g.dtype}")
    bad = np.isnan(ll) | (ll == np.inf)
    if bad.any():
        i, j = (int(k) for k in np.argwhere(bad)[0])
        raise ValueError(
            f"log_likelihood must be a number or -inf, got {float(ll[i, j])!r} at track {i}, detection {j}"
        )
    log_pair = np.where(g, ll + (math.log(pd) - math.log(lam)), -np.inf)
    miss = 1.0 - pd * pg
    log_miss = np.full(ll.shape[0], math.log(miss) if miss > 0.0 else -np.inf)
    return EventWeights(log_pair, log_miss)


def gaussian_log_likelihood(prediction: Gaussian, z: NDArray[np.floating]) -> tuple[FloatArray, FloatArray]:
    """``log N(z_j; ŷ_i, S_i)`` and the squared Mahalanobis distances ``d²_ij``, both (n, m).

    ``log g_ij = -½ d²_ij - ½ log det(2π S_i)``, with ``d²`` from
    [`agents.tracking.assign.mahalanobis_cost`][agents.tracking.mahalanobis_cost]; gate with ``d² <= γ``
    ([`agents.tracking.assign.chi2_gate`][agents.tracking.chi2_gate], whose ``p_gate`` is the ``P_G`` above).
    """
    d2 = mahalanobis_cost(prediction, z)
    cov = np.asarray(prediction.cov, dtype=np.float64)
    _, logdet = np.linalg.slogdet(2.0 * np.pi * cov)
    return -0.5 * d2 - 0.5 * logdet[:, None], d2
