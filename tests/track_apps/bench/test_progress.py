"""The bench bar's time left leaves out the first cells (they compile the kernels); a fake clock."""

from __future__ import annotations

import io

import pytest

from track_apps.bench.progress import CellBar, WarmEta


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_the_warm_up_cells_are_not_extrapolated():
    clock = FakeClock()
    eta = WarmEta(total=10, warm_up=1, clock=clock)
    assert eta.rate() is None and eta.remaining_s() is None
    clock.now = 48.0  # the first cell: 46 s of compilation, 2 s of tracking
    eta.update()
    assert eta.rate() is None and eta.remaining_s() is None  # unknown, not 9 × 48 s
    clock.now = 50.0
    eta.update()
    assert eta.rate() == pytest.approx(0.5) and eta.remaining_s() == pytest.approx(16.0)
    clock.now = 56.0
    eta.update(2)
    assert eta.rate() == pytest.approx(3 / 8) and eta.remaining_s() == pytest.approx(6 / (3 / 8))


def test_one_warm_up_cell_per_worker():
    clock = FakeClock()
    eta = WarmEta(total=8, warm_up=2, clock=clock)
    for t in (40.0, 41.0):  # each worker's first cell
        clock.now = t
        eta.update()
    assert eta.rate() is None
    clock.now = 43.0
    eta.update()
    clock.now = 44.0
    eta.update()
    assert eta.rate() == pytest.approx(2 / 3) and eta.remaining_s() == pytest.approx(4 / (2 / 3))


def test_done_means_nothing_left_and_bad_arguments_are_named():
    clock = FakeClock()
    eta = WarmEta(total=2, warm_up=1, clock=clock)
    clock.now = 1.0
    eta.update()
    clock.now = 2.0
    eta.update()
    assert eta.remaining_s() == 0.0
    with pytest.raises(ValueError, match="warm_up must be >= 1, got 0"):
        WarmEta(total=2, warm_up=0)
    with pytest.raises(ValueError, match="total must be >= 0, got -1"):
        WarmEta(total=-1, warm_up=1)


def test_the_bar_shows_the_warm_rate_and_a_question_mark_until_it_is_known():
    clock = FakeClock()
    out = io.StringIO()
    bar = CellBar(total=10, unit="cell", file=out, warm_up=1, clock=clock, mininterval=0, miniters=1)
    clock.now = 48.0
    bar.update()
    assert bar.format_dict["rate"] == 0.0  # tqdm prints 0 as '?'
    assert "<?" in bar.format_meter(**bar.format_dict)
    clock.now = 50.0
    bar.update()
    assert bar.format_dict["rate"] == pytest.approx(0.5)
    assert "<00:16" in bar.format_meter(**bar.format_dict)  # 8 cells at 2 s each, not 8 × 25 s
    bar.close()
