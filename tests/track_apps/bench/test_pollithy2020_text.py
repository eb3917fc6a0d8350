"""The pollithy2020 discussion reads its numbers and comparisons from the records: on rows with
the published page's numbers it gives the published text; on rows that order the methods otherwise
it says so."""

from __future__ import annotations

from typing import Any

import pytest

from track_apps.bench.claims import _pollithy2020_rows as data
from track_apps.bench.claims import _pollithy2020_text as text
from track_apps.bench.claims import pollithy2020 as p
from track_apps.bench.rows import Row

MM = 1e-3
LEVELS = (0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4)

#: Fig. 6 medians (mm) on cylinders, as on the published page (mc-lstm: T = 10 0.04% above T = 1000).
FIG6 = {
    "kf-cv": 0.370, "kf-cv, q tuned": 0.314, "kf-ca": 0.337, "kf-ca, q tuned": 0.250, "lstm": 0.180,
    "nll-lstm": 0.176, "mc-lstm T=10": 0.180072, "mc-lstm T=100": 0.180, "mc-lstm T=250": 0.180,
    "mc-lstm T=1000": 0.180,
}  # fmt: skip
#: Fig. 7, default belt: (e_mean, e1, e2) per noise level.
DEFAULT = {
    "kf-cv": [(0.1382, 0.114, 0.176), (0.1371, 0.113, 0.175), (0.1382, 0.114, 0.174), (0.1381, 0.115, 0.173),
              (0.1377, 0.115, 0.171), (0.1397, 0.118, 0.171)],
    "kf-ca": [(0.0888, 0.051, 0.326), (0.1336, 0.093, 0.237), (0.1269, 0.100, 0.173), (0.1288, 0.104, 0.168),
              (0.1319, 0.109, 0.167), (0.1352, 0.113, 0.168)],
    "lstm (line-searched s·I)": [(0.1124, 0.083, 0.174), (0.1149, 0.085, 0.176), (0.1136, 0.084, 0.176),
                                 (0.1115, 0.082, 0.174), (0.1094, 0.080, 0.173), (0.1073, 0.078, 0.173)],
    "nll-lstm": [(0.0886, 0.054, 0.248), (0.1041, 0.068, 0.225), (0.1227, 0.094, 0.179),
                 (0.1225, 0.095, 0.171), (0.1208, 0.094, 0.169), (0.1200, 0.094, 0.167)],
    "mc-lstm T=250": [(0.1278, 0.102, 0.172), (0.1272, 0.101, 0.171), (0.1257, 0.100, 0.170),
                      (0.1237, 0.098, 0.168), (0.1224, 0.097, 0.167), (0.1205, 0.095, 0.165)],
}  # fmt: skip
SEPARATE = {
    "kf-cv": [1e-4] * 5 + [3e-4], "kf-ca": [1e-4, 1e-4, 3e-4, 3e-4, 3e-4, 3e-4],
    "lstm (line-searched s·I)": [0.0] * 6, "nll-lstm": [0.0] * 6, "mc-lstm T=250": [0.0] * 6,
}  # fmt: skip
DENSE = {"kf-cv": [0.0216, 0.0225, 0.0241], "kf-ca": [0.0207, 0.0216, 0.0226],
         "lstm (line-searched s·I)": [0.0] * 3, "nll-lstm": [0.0] * 3}  # fmt: skip
#: Table I: the NLL-LSTM's raw area (mm²) per noise level.
AREA = [0.0996, 0.1815, 0.3782, 0.6449, 0.9171, 1.1273]

PUBLISHED = """\
- **The Kalman filters predict worse than the LSTMs here (claims 3–4), the opposite of the
  paper.** Our belt's motion is a smooth, deterministic function of the state: Coulomb friction
  pulls every particle toward belt speed along one profile, which a CV or CA model can only
  absorb as process noise, while a recurrent model trained on ≈10⁴ simulated tracks learns the
  profile itself. The paper's Fig. 6 is on real peppercorns, which roll and bounce in ways the
  simulation does not have, with LSTMs trained on a few thousand tracks. Tuning q for the noise
  level narrows the gap (kf-ca's median falls by a quarter) but does not close it. The medians
  of the learned models stay below 0.3 mm as in the paper; those of the Kalman filters with the
  tracker's default q do not (claim 1).
- **MC dropout hardly depends on T (claim 2)** because the shipped mc-lstm drops units with
  p = 0.05%: its training grid found the validation likelihood nearly flat over 0.05–1% and
  best at the smallest rate (BENCHMARKS.md), so ≈91% of any T samples are the plain network.
  The paper chose 0.2%, where T matters more; we did not retrain to test that. The raw
  covariance is dominated by τ⁻¹ (≈10⁴ × the sample variance), so the uncalibrated model
  over-estimates its uncertainty as the paper found (claim 15), and r ≈ 8.5·10⁻⁵ undoes it.
- **Association errors on our belt come from merged blobs, not from the added noise (Fig. 7).**
  At the paper's load the camera sees touching particles as one blob; a blob's members share
  one detection, and that, not the 0–0.5 mm noise, is where tracks swap particles: every
  method's e_mean is 0.09–0.14 at every noise level, at most 0.05 apart. With every
  particle sensed on its own the gnn makes almost no association errors at this load (e_mean
  ≤ 0.0003 for every method and noise level: the claims on that panel cannot be tested),
  because particles lie millimetres apart and 0.5 mm of noise does not confuse them. At twice
  the load the Kalman filters make errors (e_mean 0.021–0.024, rising a little with the noise)
  and the LSTMs none: the predictor matters far more than the noise. The paper's DEM
  cylinders gave errors that grew with the noise; its particle spacing and its tracker (ours
  adds a second-chance association of leftover tracks) differ from ours.
- **NLL-LSTM against the line-searched LSTM (claim 6)**: nll-lstm is better at 0 and 0.1 mm and
  worse from 0.2 mm on. Its variance grows with the noise (Table I) and so do its gates, which
  lets tracks jump between the members of a blob (e1 rises from 0.05 to 0.09); the LSTM's fixed
  s·I, line-searched for the whole 0–0.5 mm range, does not widen. At 0 mm the Kalman CA and
  the NLL-LSTM have the fewest tracks holding two particles but fragment more (e2 0.25–0.33):
  the sensor declares no noise, so their gates are tight. The dropout LSTM is not the worst
  (claim 8): kf-cv is, at every noise level.
- **Calibration (claims 14–16)**: the NLL-LSTM's raw variances follow the diagonal in the body
  of the curve but cover only ≈99.55% at the 0.999 gate level (the first predictions of a track
  are heavy-tailed); r = 1.85 fixes the gate level and makes the body over-cover — the
  one-factor calibration that the paper itself calls an oversimplification (Sec. VI).
- **Fig. 8 and Table I agree with the paper**: r ≈ −0.54 against −0.59, and the area grows
  0.10 → 1.13 mm² over 0 → 0.5 mm against 0.17 → 1.04 mm². Ours grows almost linearly, the
  paper's slowly and then steeply; at no added noise ours is smaller, as simulated centroids
  have no noise of their own (the peppercorn data have some).
- Figures, numbers and verdicts are regenerated from the records by the command above; the
  records of a full run are not shipped (≈450 JSON files). Wall times depend on the machine
  and its load; an idle machine is faster."""


def row(agent: str, predictor: str, env: dict[str, Any], kwargs: Any = (), **mean: float) -> Row:
    params = (*sorted(env.items()), *((f"agent.{k}", v) for k, v in kwargs))
    return Row(data.ENV, tuple(params), agent, predictor, 2, dict(mean), {k: 0.0 for k in mean})


def rows_of(fig6=FIG6, default=DEFAULT, dense=DENSE, area=AREA, nll_r=1.85, cover=0.9955) -> list[Row]:
    """Rows with the figures' keys: Fig. 6 (all kinds), Fig. 7 (three belts), Table I, Figs. 3–4."""
    out = []
    for kind in data.KINDS:
        for label, predictor, kw in data.FIG6:
            if kind != "cylinder" and predictor not in ("lstm", "nll-lstm"):
                continue
            median = fig6[label] * (1.0 if kind == "cylinder" else 1.1) * MM
            keys: dict[str, float] = {"track_error_p50": median, "track_error_p95": 1.4 * median}
            if label == "mc-lstm T=250" and kind == "cylinder":
                keys |= {"calibration_error_raw": 0.477, "calibration_error": 0.410,
                         "reliability_raw@0.20": 1.0, "reliability_raw@0.999": 1.0,
                         "reliability@0.999": 1.0, "calibration_scale": 8.5e-5}  # fmt: skip
            if label == "nll-lstm" and kind == "cylinder":
                keys |= {"calibration_error_raw": 0.049, "calibration_error": 0.174,
                         "reliability_raw@0.999": cover, "reliability@0.999": 0.9993,
                         "calibration_scale": nll_r, "aleatoric_area_mean": area[1] * 1e-6,
                         "aleatoric_n": 95884}  # fmt: skip
            env = {"merge_touching": False, "noise_std": 1e-4, "particle_kind": kind}
            out.append(row("one-step", predictor, env, kw, **keys))
    for n, a in zip(LEVELS, area, strict=True):
        if n != 1e-4:
            env = {"merge_touching": False, "noise_std": n, "particle_kind": "cylinder"}
            keys = {"aleatoric_area_mean": a * 1e-6, "calibration_scale": nll_r, "aleatoric_n": 95884}
            out.append(row("one-step", "nll-lstm", env, (), **keys))
    panels = (
        ("fig7", default, LEVELS),
        ("fig7_separate", {k: [(v, 0.0, 0.0) for v in vs] for k, vs in SEPARATE.items()}, LEVELS),
        ("fig7_dense", {k: [(v, 0.0, 0.0) for v in vs] for k, vs in dense.items()}, (0.0, 2e-4, 5e-4)),
    )
    for variant, values, levels in panels:
        for label, predictor, kw in data.FIG7:
            if label not in values:
                continue
            for n, (e, e1, e2) in zip(levels, values[label], strict=True):
                env = {"noise_std": n, **data.VARIANTS[variant][0]}
                out.append(
                    row("gnn", predictor, env, (("predict_sorting", False), *kw), e_mean=e, e1=e1, e2=e2)
                )
    return out


def page(rows: list[Row], monkeypatch: pytest.MonkeyPatch, r: float = -0.54) -> str:
    monkeypatch.setattr(text, "age_series", lambda row, scale=1.0: {"r": r})
    monkeypatch.setattr(p, "age_series", lambda row, scale=1.0: {"r": r})
    claims = [
        *p.fig6_claims(rows, "fig"),
        *p.fig7_claims(rows, {v: "fig" for v in data.VARIANTS}),
        *p.reliability_claims(rows, "fig"),
        *p.aleatoric_claims(rows, "fig"),
    ]
    assert len(claims) == 18
    return "\n".join(text.discussion(rows, claims, 454))


def test_the_published_records_give_the_published_discussion(monkeypatch):
    assert page(rows_of(), monkeypatch) == PUBLISHED


def test_the_discussion_follows_records_that_order_the_methods_otherwise(monkeypatch):
    # the Kalman filters predict best; the NLL-LSTM is worse than the LSTM at low noise and better
    # from 0.3 mm on; the dropout LSTM is the worst at 0.5 mm; the areas do not grow
    fig6 = {**FIG6, "kf-ca, q tuned": 0.150}
    default = {k: list(v) for k, v in DEFAULT.items()}
    nll, lstm = default["nll-lstm"], default["lstm (line-searched s·I)"]
    default["nll-lstm"] = [(lstm[i][0] + (0.01 if i < 3 else -0.01), *nll[i][1:]) for i in range(6)]
    default["mc-lstm T=250"][5] = (0.1500, 0.12, 0.17)
    dense = {**DENSE, "kf-cv": [0.0241, 0.0225, 0.0216]}
    area = [0.0996, 0.1815, 0.1782, 0.6449, 0.9171, 1.1273]
    got = page(rows_of(fig6=fig6, default=default, dense=dense, area=area, nll_r=0.8), monkeypatch, r=-0.1)
    assert got != PUBLISHED
    assert "The Kalman filters predict at least as well as the LSTMs here (claims 3–4), as in the" in got
    assert "nll-lstm is better from 0.3 mm on and\n  worse at 0, 0.1 and 0.2 mm." in got
    assert "Its variance does not grow with the noise (Table I)" in got
    assert "The dropout LSTM is the worst\n  at 0.5 mm (claim 8)." in got
    assert "not rising with the noise" in got
    assert "Fig. 8 and Table I do not agree with the paper**: r ≈ −0.10" in got
    assert "Ours does not grow steadily" in got
    assert "r = 0.80 fixes the gate level and makes the body under-cover" in got
    assert "e_mean is 0.09–0.15 at every noise level" in got
