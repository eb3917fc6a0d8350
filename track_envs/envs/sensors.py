"""Point sensor model: missed detections, additive Gaussian noise, uniform clutter.

For targets at true positions ``x_i`` (n, D) one frame of detections is drawn as

* target ``i`` is detected with probability ``p_detect`` (independent Bernoulli trials, no draw
  when ``p_detect = 1``);
* a detection of target ``i`` is ``z = x_i + v``, ``v ~ N(0, noise_std² I_D)``;
* ``K ~ Poisson(clutter_rate)`` clutter detections, uniform over the clutter box.

Every draw comes from the generator passed in (the environment's ``np_random``) in a fixed
order, so a seed fixes the frame bit for bit. Rows are returned unshuffled; the environment
shuffles them so that row order never reveals identity.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

# the checks of the sensor arguments (re-exported from track_envs.infra.arguments)
from track_envs.infra.arguments import check_non_negative, check_positive, check_probability
from track_envs.infra.compiled import njit

__all__ = ["CLUTTER_ID", "check_non_negative", "check_positive", "check_probability", "sense_points"]

CLUTTER_ID = -1


def sense_points(
    positions: NDArray[np.floating],
    ids: NDArray[np.integer],
    rng: np.random.Generator,
    *,
    noise_std: float,
    p_detect: float,
    clutter_rate: float,
    clutter_low: NDArray[np.floating],
    clutter_high: NDArray[np.floating],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Draw one frame of point detections.

    Args:
        positions: True positions of the targets in view, (n, D).
        ids: Truth ids of those targets, (n,).
        rng: The generator every draw comes from.
        noise_std: Noise standard deviation per axis, >= 0.
        p_detect: Detection probability in [0, 1].
        clutter_rate: Mean number of clutter detections per frame, >= 0.
        clutter_low: Lower corner of the clutter box, (D,).
        clutter_high: Upper corner of the clutter box, (D,).

    Returns:
        ``(z, source)``: detections (k, D) and the truth id behind each row (k,), with
            [`CLUTTER_ID`][track_envs.envs.sensors.CLUTTER_ID] (-1) for clutter. Target detections come first,
            clutter last.
    """
    x = np.asarray(positions, dtype=np.float64)
    n, dim = x.shape
    if p_detect < 1.0:
        uniform = rng.random(size=(n,))
        noise = rng.standard_normal(size=(n, dim))
        z, source = _detect(x, np.asarray(ids, dtype=np.int64), uniform, noise, p_detect, noise_std)
    else:  # a certain detection needs no draw
        z = rng.standard_normal(size=(n, dim))
        z *= noise_std
        z += x
        source = np.array(ids, dtype=np.int64)
    k = int(rng.poisson(clutter_rate)) if clutter_rate > 0 else 0
    if k:
        lo = np.asarray(clutter_low, dtype=np.float64)
        hi = np.asarray(clutter_high, dtype=np.float64)
        clutter = lo + rng.random((k, dim)) * (hi - lo)
        z = np.concatenate([z, clutter])
        source = np.concatenate([source, np.full(k, CLUTTER_ID, dtype=np.int64)])
    return z, source


@njit(cache=True)
def _detect(
    x: NDArray[np.float64],
    ids: NDArray[np.int64],
    uniform: NDArray[np.float64],
    noise: NDArray[np.float64],
    p_detect: float,
    noise_std: float,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Rows ``x_i + noise_std ε_i`` and ids of the targets with ``uniform_i < p_detect``."""
    n, dim = x.shape
    count = 0
    for i in range(n):
        if uniform[i] < p_detect:
            count += 1
    z = np.empty((count, dim))
    source = np.empty(count, np.int64)
    k = 0
    for i in range(n):
        if uniform[i] < p_detect:
            for d in range(dim):
                z[k, d] = x[i, d] + noise[i, d] * noise_std
            source[k] = ids[i]
            k += 1
    return z, source
