"""Uncertainty area of each prediction against the age of its track, with Pearson's r.

Pollithy, Reith-Braun, Pfaff, Hanebeck, "Estimating Uncertainties of Recurrent Neural Networks in
Application to Multitarget Tracking" (2020), Table I and Fig. 8, measure a predicted covariance
``Σ`` by the area of the rectangle that bounds its 1σ ellipse,

    A = 4 σ_x σ_y = 4 sqrt(Σ_xx Σ_yy)          (sensor units², e.g. m²),

and relate it to the number of observations ``a`` the track had when it made the prediction
(``a = 1``: predicted from the first measurement alone). Pearson's correlation over all
predictions is computed exactly from streamed moments,

    r = (n Σ a A − Σ a Σ A) / sqrt((n Σ a² − (Σ a)²) (n Σ A² − (Σ A)²)),

and per age ``a = 1 … max_age`` (older tracks fall into the last bin) the count, the mean and
the mean square of ``A`` are kept, so the per-age scatter — and ``r`` of several episodes pooled —
can be rebuilt from the flat keys alone ([`pooled_r`][track_envs.metrics.aleatoric.pooled_r]).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Default number of age bins (a track of the belt is seen ≈31–33 times, rarely more than 60).
MAX_AGE = 64


def area_key(kind: str, age: int) -> str:
    """Key of a per-age statistic: ``aleatoric_count@3``, ``aleatoric_area@3``, ``aleatoric_area_sq@3``."""
    return f"aleatoric_{kind}@{age}"


def bounding_area(cov: ArrayLike) -> NDArray[np.float64]:
    """``4 σ_x σ_y`` of covariances (n, D, D), D ≥ 2: the rectangle bounding each 1σ ellipse in
    the first two axes."""
    c = np.asarray(cov, dtype=np.float64)
    if c.ndim != 3 or c.shape[1] < 2 or c.shape[1] != c.shape[2]:
        raise ValueError(f"covariances must have shape (n, D, D) with D >= 2, got {c.shape}")
    return np.asarray(4.0 * np.sqrt(np.clip(c[:, 0, 0], 0, None) * np.clip(c[:, 1, 1], 0, None)))


def pearson_from_moments(n: float, sx: float, sy: float, sxx: float, syy: float, sxy: float) -> float:
    """Pearson's r from ``n, Σx, Σy, Σx², Σy², Σxy`` (NaN when either variance is 0)."""
    vx = n * sxx - sx * sx
    vy = n * syy - sy * sy
    if n < 2 or vx <= 0 or vy <= 0:
        return float("nan")
    return float((n * sxy - sx * sy) / math.sqrt(vx * vy))


def pooled_r(counts: ArrayLike, means: ArrayLike, mean_squares: ArrayLike) -> float:
    """Pearson's r between age and area from per-age bins (ages 1, 2, …): count, mean area and
    mean squared area per bin (bins with count 0 may hold NaN)."""
    n = np.asarray(counts, dtype=np.float64)
    m = np.nan_to_num(np.asarray(means, dtype=np.float64))
    q = np.nan_to_num(np.asarray(mean_squares, dtype=np.float64))
    a = np.arange(1, len(n) + 1, dtype=np.float64)
    s_y = n * m
    return pearson_from_moments(
        n.sum(), (a * n).sum(), s_y.sum(), (a * a * n).sum(), (n * q).sum(), (a * s_y).sum()
    )


class AleatoricArea:
    """Streaming bounding-box area ``4 σ_x σ_y`` of predicted covariances with their track age.

    ``update(cov, age)`` adds covariances (n, D, D) and the number of observations (n,) of each
    predicting track (integers >= 1). ``compute()`` gives ``aleatoric_area_mean``,
    ``aleatoric_area_r`` (Pearson's r of age and area over every prediction), ``aleatoric_n`` and,
    per age bin ``a = 1 … max_age``, ``aleatoric_count@a``, ``aleatoric_area@a`` (mean, NaN when
    empty) and ``aleatoric_area_sq@a`` (mean square).

    Args:
        max_age: Number of age bins; older tracks are counted in the last one.
    """

    def __init__(self, max_age: int = MAX_AGE) -> None:
        if not (isinstance(max_age, int) and max_age >= 1):
            raise ValueError(f"max_age must be an integer >= 1, got {max_age!r}")
        self.max_age = max_age
        self.reset()

    def reset(self) -> None:
        """Forget everything added."""
        self._moments = np.zeros(6)  # n, Σa, ΣA, Σa², ΣA², ΣaA
        self._bins = np.zeros((3, self.max_age))  # count, ΣA, ΣA² per age

    def update(self, cov: ArrayLike, age: ArrayLike) -> None:
        """Add covariances ``cov`` (n, D, D) of predictions made by tracks of ``age`` (n,) observations."""
        area = bounding_area(cov)
        a = np.asarray(age).reshape(-1)
        if a.shape != area.shape:
            raise ValueError(f"age must have shape ({len(area)},), got {a.shape}")
        if len(a) and (not np.issubdtype(a.dtype, np.integer) or a.min() < 1):
            raise ValueError(f"ages must be integers >= 1, got dtype {a.dtype} and minimum {a.min()!r}")
        ok = np.isfinite(area)
        area, af = area[ok], a[ok].astype(np.float64)
        self._moments += [
            len(area),
            af.sum(),
            area.sum(),
            (af * af).sum(),
            (area * area).sum(),
            (af * area).sum(),
        ]
        idx = np.minimum(a[ok], self.max_age) - 1
        self._bins[0] += np.bincount(idx, minlength=self.max_age)
        self._bins[1] += np.bincount(idx, weights=area, minlength=self.max_age)
        self._bins[2] += np.bincount(idx, weights=area * area, minlength=self.max_age)

    def compute(self) -> dict[str, float]:
        """The keys listed in the class docstring."""
        n, sa, sy, saa, syy, say = (float(v) for v in self._moments)
        out = {
            "aleatoric_area_mean": sy / n if n else float("nan"),
            "aleatoric_area_r": pearson_from_moments(n, sa, sy, saa, syy, say),
            "aleatoric_n": n,
        }
        count, total, squares = self._bins
        with np.errstate(invalid="ignore", divide="ignore"):
            mean, mean_sq = total / count, squares / count
        for k in range(self.max_age):
            out[area_key("count", k + 1)] = float(count[k])
            out[area_key("area", k + 1)] = float(mean[k])
            out[area_key("area_sq", k + 1)] = float(mean_sq[k])
        return out
