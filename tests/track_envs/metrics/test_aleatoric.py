"""Uncertainty area over track age (track_envs/metrics/aleatoric.py) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import pearsonr

from track_envs.metrics.aleatoric import AleatoricArea, area_key, bounding_area, pooled_r


def _diag(sx, sy):
    cov = np.zeros((len(sx), 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = np.square(sx), np.square(sy)
    return cov


def test_bounding_area_is_four_sigma_x_sigma_y():
    np.testing.assert_allclose(bounding_area(_diag([1.0, 0.5], [2.0, 0.1])), [8.0, 0.2])
    # a correlation leaves the marginal stds and so the bounding box unchanged
    cov = np.array([[[4.0, 1.5], [1.5, 1.0]]])
    assert bounding_area(cov)[0] == pytest.approx(4 * 2.0 * 1.0)
    with pytest.raises(ValueError, match="shape"):
        bounding_area(np.zeros((3, 2)))


def test_mean_r_and_bins_match_numpy_and_scipy():
    rng = np.random.default_rng(0)
    age = rng.integers(1, 30, 500)
    sx = 1.0 / age + 0.05 * rng.random(500)
    sy = 0.5 / np.sqrt(age) + 0.05 * rng.random(500)
    m = AleatoricArea(max_age=40)
    m.update(_diag(sx[:200], sy[:200]), age[:200])
    m.update(_diag(sx[200:], sy[200:]), age[200:])
    out = m.compute()
    area = 4 * sx * sy
    assert out["aleatoric_area_mean"] == pytest.approx(area.mean())
    assert out["aleatoric_area_r"] == pytest.approx(pearsonr(age, area).statistic)
    assert out["aleatoric_n"] == 500
    for a in (1, 7, 29):
        sel = area[age == a]
        assert out[area_key("count", a)] == len(sel)
        assert out[area_key("area", a)] == pytest.approx(sel.mean())
        assert out[area_key("area_sq", a)] == pytest.approx(np.mean(sel**2))
    assert math.isnan(out[area_key("area", 35)]) and out[area_key("count", 35)] == 0
    # r rebuilt from the per-age bins alone (every age inside the bins) is the same r
    bins = [[out[area_key(k, a)] for a in range(1, 41)] for k in ("count", "area", "area_sq")]
    assert pooled_r(*bins) == pytest.approx(out["aleatoric_area_r"])


def test_old_tracks_share_the_last_bin_and_bad_ages_are_refused():
    m = AleatoricArea(max_age=3)
    m.update(_diag([1.0, 1.0, 1.0], [1.0, 2.0, 3.0]), np.array([3, 4, 9]))
    out = m.compute()
    assert out[area_key("count", 3)] == 3
    assert out[area_key("area", 3)] == pytest.approx(8.0)
    with pytest.raises(ValueError, match="integers >= 1"):
        m.update(_diag([1.0], [1.0]), np.array([0]))
    with pytest.raises(ValueError, match="integers >= 1"):
        m.update(_diag([1.0], [1.0]), np.array([1.5]))


def test_constant_area_has_no_correlation():
    m = AleatoricArea()
    m.update(_diag([1.0, 1.0], [1.0, 1.0]), np.array([1, 2]))
    assert math.isnan(m.compute()["aleatoric_area_r"])
