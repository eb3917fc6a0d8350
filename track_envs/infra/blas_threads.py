"""BLAS threads of a tracker frame's small products: one thread by default, whatever BLAS defaults to.

A tracker frame multiplies small matrices (the belt LSTM's 150 × 69 by 69 × 256 step). OpenBLAS
splits every GEMM with ``M·N·K`` above ≈ 2.6·10⁵ multiply-adds (GEMVs above ``m·n`` ≈ 9,216)
over all its threads, and its workers spin-wait on each other: on an idle two-core machine the
split gains nothing at these sizes, and with another process busy on the other core a
descheduled worker stalls every product (the belt step took 50x its one-thread time). So the
per-frame steps run inside [`frame_blas`][track_envs.infra.blas_threads.frame_blas], which limits the BLAS
libraries to [`frame_threads`][track_envs.infra.blas_threads.frame_threads] threads (1 by default) for the
duration of the block and restores the previous count when it leaves; the same products on one thread give the
same bits (OpenBLAS splits a GEMM over rows and columns, never along the summed axis; tested).

The limit covers every BLAS library loaded when it is first entered, numpy's and scipy's (the one
behind numba's ``np.dot`` in compiled kernels; `scipy.linalg` is imported for that). The
libraries are found by `threadpoolctl` once per process and set by their own functions
([`_get_set`][track_envs.infra.blas_threads._get_set]): entering and leaving costs three library calls per
BLAS, a few µs (``threadpoolctl.threadpool_limits`` finds the libraries again on every call, ≈300 µs). Blocks
nest, and may be open on several Python threads at once: the smallest open limit holds, and the
counts saved by the first block come back when the last leaves. The count is process wide: while
a block is open, BLAS products of other Python threads of the process run on the limited threads
too.

[`set_frame_threads`][track_envs.infra.blas_threads.set_frame_threads] changes the limit (``None``: leave BLAS
at its own count, the behaviour before the limit existed; what `benchmarks.bench_lstm_threads` compares
against).
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from types import TracebackType
from typing import Any

#: The default number of BLAS threads inside [`frame_blas`][track_envs.infra.blas_threads.frame_blas].
DEFAULT_FRAME_THREADS = 1

_frame_threads: int | None = DEFAULT_FRAME_THREADS
_controllers: list[Any] | None = None
_functions: list[tuple[Callable[[], int], Callable[[int], Any]]] = []
_lock = threading.Lock()


def _blas_controllers() -> list[Any]:
    """threadpoolctl's controllers of the loaded BLAS libraries (built on first use)."""
    global _controllers, _functions
    if _controllers is None:
        import numpy  # noqa: F401  (its BLAS)
        import scipy.linalg  # noqa: F401  (scipy's BLAS, behind numba's np.dot)
        from threadpoolctl import ThreadpoolController

        controllers = list(ThreadpoolController().select(user_api="blas").lib_controllers)
        _functions = [_get_set(c) for c in controllers]
        _controllers = controllers
    return _controllers


def _get_set(controller: Any) -> tuple[Callable[[], int], Callable[[int], Any]]:
    """The get and set functions of a library's thread count: OpenBLAS's own (pthreads layer)
    called directly, else the controller's methods.

    threadpoolctl's ``set_num_threads`` of a pthreads OpenBLAS acts only from the first Python
    thread that called it and does nothing from any other while that one lives; a tracker
    stepping on a worker thread must still get its limit, so the library's
    ``openblas_set_num_threads`` is called instead (it is process wide;
    [`_lock`][track_envs.infra.blas_threads._lock] orders the calls of this module).
    """
    if controller.internal_api == "openblas" and getattr(controller, "threading_layer", "") != "openmp":
        for prefix, suffix in itertools.product(("", "scipy_"), ("", "64_", "_64")):
            get = getattr(controller.dynlib, f"{prefix}openblas_get_num_threads{suffix}", None)
            put = getattr(controller.dynlib, f"{prefix}openblas_set_num_threads{suffix}", None)
            if get is not None and put is not None:
                return get, put
    return controller.get_num_threads, controller.set_num_threads


def blas_info() -> list[dict[str, Any]]:
    """The BLAS libraries the limit acts on: ``threadpoolctl``'s info (library, version, kernel
    ``architecture``, current ``num_threads``) of each."""
    return [c.info() for c in _blas_controllers()]


def frame_threads() -> int | None:
    """The BLAS threads of [`frame_blas`][track_envs.infra.blas_threads.frame_blas] blocks (``None``: BLAS's
    own count)."""
    return _frame_threads


def set_frame_threads(threads: int | None) -> None:
    """Set the BLAS threads of [`frame_blas`][track_envs.infra.blas_threads.frame_blas] blocks: an integer ≥
    1, or ``None`` to leave BLAS at its own count.

    Raises:
        ValueError: ``threads`` neither ``None`` nor an integer ≥ 1.
    """
    global _frame_threads
    if threads is not None and not (isinstance(threads, int) and not isinstance(threads, bool)):
        raise ValueError(f"threads must be an integer >= 1 or None, got {threads!r}")
    if threads is not None and threads < 1:
        raise ValueError(f"threads must be an integer >= 1 or None, got {threads!r}")
    _frame_threads = threads


class BlasLimit:
    """Context manager: the BLAS libraries on at most ``threads`` threads inside the block.

    ``threads=None`` does nothing. Blocks may nest and may be open on several Python threads at
    once: while any is open every library runs on the smallest open limit (or its own count, if
    smaller); the counts from before the first block come back when the last one leaves.
    """

    __slots__ = ("threads",)

    def __init__(self, threads: int | None) -> None:
        self.threads = threads

    def __enter__(self) -> BlasLimit:
        if self.threads is not None:
            with _lock:
                if not _open:
                    _blas_controllers()
                    _saved[:] = [get() for get, _ in _functions]
                    _current[:] = _saved
                _open.append(self.threads)
                _apply()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self.threads is not None:
            with _lock:
                _open.remove(self.threads)
                _apply()


#: The limits of the open blocks, the counts from before the first, the counts set now.
_open: list[int] = []
_saved: list[int] = []
_current: list[int] = []


def _apply() -> None:
    """Set every library to ``min(its saved count, the smallest open limit)``, or back to its saved
    count when no block is open; only the counts that change are set (caller holds ``_lock``)."""
    limit = min(_open) if _open else None
    for i, (_, put) in enumerate(_functions):
        n = _saved[i] if limit is None else min(_saved[i], limit)
        if _current[i] != n:
            put(n)
            _current[i] = n


def blas_limit(threads: int | None = 1) -> BlasLimit:
    """The BLAS libraries on at most ``threads`` threads inside a ``with`` block
    ([`BlasLimit`][track_envs.infra.blas_threads.BlasLimit])."""
    return BlasLimit(threads)


def frame_blas() -> BlasLimit:
    """The limit of a tracker frame's small products: [`blas_limit`][track_envs.infra.blas_threads.blas_limit]
    of [`frame_threads`][track_envs.infra.blas_threads.frame_threads]."""
    return BlasLimit(_frame_threads)


__all__ = [
    "DEFAULT_FRAME_THREADS",
    "BlasLimit",
    "blas_info",
    "blas_limit",
    "frame_blas",
    "frame_threads",
    "set_frame_threads",
]
