"""The bench's progress bar, whose time left leaves out the first cells' warm-up.

The first cell a worker runs also compiles the numba kernels (tens of seconds on a fresh clone),
so a rate over every finished cell (tqdm's own) extrapolates that compilation to every cell
left: a run of five minutes showed over an hour to go. [`WarmEta`][track_apps.bench.progress.WarmEta] takes
the rate from the cells finished after the first ``warm_up`` (one per worker: the ones that compiled),

.. math::

    \\text{rate} = \\frac{n - w}{c_n - c_w}, \\qquad \\text{left} = \\frac{N - n}{\\text{rate}},

with ``c_k`` the clock when the ``k``-th cell finished, ``n`` cells finished of ``N`` and
``w = warm_up``; until cell ``w + 1`` finished the rate (and so the time left) is unknown, shown
as ``?``. [`CellBar`][track_apps.bench.progress.CellBar] is the tqdm bar that shows it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from tqdm import tqdm


class WarmEta:
    """The cell rate and time left of a run, from the cells finished after the warm-up ones.

    Args:
        total: Cells to run.
        warm_up: Cells whose time is left out of the rate: the first to finish (one per worker).
        clock: Seconds, monotonic (default `time.monotonic`; a test passes a fake one).

    Raises:
        ValueError: ``total`` below 0 or ``warm_up`` below 1.
    """

    def __init__(self, total: int, warm_up: int, clock: Callable[[], float] = time.monotonic):
        if total < 0:
            raise ValueError(f"total must be >= 0, got {total}")
        if warm_up < 1:
            raise ValueError(f"warm_up must be >= 1, got {warm_up}")
        self.total = total
        self.warm_up = warm_up
        self.clock = clock
        self.done = 0
        self._warm_at: float | None = None
        self._warm_done = 0
        self._last_at: float | None = None

    def update(self, n: int = 1) -> None:
        """``n`` more cells finished now."""
        now = self.clock()
        self.done += n
        if self._warm_at is None and self.done >= self.warm_up:
            self._warm_at, self._warm_done = now, self.done
        self._last_at = now

    def rate(self) -> float | None:
        """Cells per second after the warm-up, ``None`` until a cell finished after it."""
        if self._warm_at is None or self._last_at is None or self.done <= self._warm_done:
            return None
        elapsed = self._last_at - self._warm_at
        return (self.done - self._warm_done) / elapsed if elapsed > 0 else None

    def remaining_s(self) -> float | None:
        """Seconds left at [`rate`][track_apps.bench.progress.WarmEta.rate], ``None`` while it is unknown."""
        rate = self.rate()
        return None if rate is None else max(self.total - self.done, 0) / rate


class CellBar(tqdm):
    """A tqdm bar over cells whose rate and time left are [`WarmEta`][track_apps.bench.progress.WarmEta]'s
    (``?`` until known).

    Args:
        *args: tqdm's.
        warm_up: Cells left out of the rate (one per worker).
        clock: The [`WarmEta`][track_apps.bench.progress.WarmEta] clock.
        **kwargs: tqdm's (``total`` is required).
    """

    def __init__(
        self, *args: Any, warm_up: int = 1, clock: Callable[[], float] = time.monotonic, **kwargs: Any
    ):
        self.eta = WarmEta(int(kwargs.get("total") or 0), warm_up, clock)
        super().__init__(*args, **kwargs)

    def update(self, n: float | None = 1) -> bool | None:
        """Count ``n`` finished cells (in the bar and the ETA)."""
        self.eta.update(int(n or 0))
        return super().update(n)

    @property
    def format_dict(self) -> dict[str, Any]:
        """tqdm's, with the rate after the warm-up (0: shown as ``?``, as is the time left)."""
        out = dict(super().format_dict)
        out["rate"] = self.eta.rate() or 0.0
        return out
