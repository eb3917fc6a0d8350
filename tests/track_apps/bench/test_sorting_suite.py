"""The sorting suite: what it runs, and its error-distribution plot."""

from __future__ import annotations

import matplotlib

from track_apps.bench import expand, load_suite
from track_apps.bench.tables import Row, best_rows, headline, sorting_error_figure

matplotlib.use("Agg")

#: The belt predictors the sorting suite compares: the Kalman filters and the learned ones.
SORTING_PREDICTORS = ("kf-cv", "kf-ca", "lstm", "nll-lstm", "mc-lstm")
#: Pollithy et al. (2020), Fig. 7: the measurement noise on the belt from 0 to 0.5 mm.
NOISE_SWEEP = (0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4)
#: Nozzle bars of the sorting suite: close to the camera window and farther downstream (m).
NOZZLE_OFFSETS = (0.02, 0.10)


def test_the_sorting_suite_compares_every_belt_predictor_over_noise_and_two_nozzle_bars():
    cells = expand(load_suite("sorting"))
    assert {c.predictor for c in cells} == set(SORTING_PREDICTORS)
    assert {dict(c.env_kwargs)["noise_std"] for c in cells} == set(NOISE_SWEEP)
    assert {dict(c.env_kwargs)["nozzle_offset"] for c in cells} == set(NOZZLE_OFFSETS)
    assert len(cells) == len(SORTING_PREDICTORS) * len(NOISE_SWEEP) * len(NOZZLE_OFFSETS) * 3
    assert max(NOISE_SWEEP) == 5e-4 and min(NOISE_SWEEP) == 0.0


def _row(predictor: str, noise: float, hit: float, scale: float) -> Row:
    mean = {"sorting_hit_rate": hit}
    for axis, unit in (("time", "ms"), ("lateral", "mm")):
        for q in (50, 90, 95, 99):
            mean[f"sorting_{axis}_p{q}_{unit}"] = scale * q / 50
    setting = (("noise_std", noise), ("nozzle_offset", 0.02))
    return Row("BeltSorter-v0", setting, "gnn", predictor, 1, mean, dict.fromkeys(mean, 0.0))


def test_sorting_rows_get_the_headline_the_best_mark_and_the_error_plot():
    rows = [_row("kf-cv", n, 0.7, 1.0) for n in (0.0, 1e-4)] + [
        _row("nll-lstm", n, 0.9, 0.1) for n in (0.0, 1e-4)
    ]
    assert "sorting_hit_rate" in headline(rows)
    assert best_rows(rows, "sorting_hit_rate") == {2, 3}  # higher is better, per setting
    assert best_rows(rows, "sorting_time_p95_ms") == {2, 3}  # lower is better
    fig = sorting_error_figure(rows)
    assert fig is not None
    lines = fig.axes[0].get_lines()
    assert len([line for line in lines if line.get_marker() == "o"]) == 2  # noise 1e-4 only
    assert (
        sorting_error_figure([Row("SineTarget-v0", (), "pf", "-", 1, {"rmse": 1.0}, {"rmse": 0.0})]) is None
    )
