"""The BLAS thread limit of a frame's small products (track_envs/infra/blas_threads.py): the
counts inside and after a block, nesting, other Python threads, the setting and its errors."""

from __future__ import annotations

import threading

import pytest
from threadpoolctl import threadpool_limits

from track_envs.infra import blas_threads
from track_envs.infra.blas_threads import (
    blas_info,
    blas_limit,
    frame_blas,
    frame_threads,
    set_frame_threads,
)


def counts() -> list[int]:
    """The thread count of every BLAS library the limit acts on."""
    return [int(i["num_threads"]) for i in blas_info()]


@pytest.fixture
def two_threads():
    """Every BLAS library on two threads for the test (what a default install has on two cores)."""
    blas_info()  # the libraries loaded (numpy's and scipy's) before threadpoolctl looks
    with threadpool_limits(2, user_api="blas"):
        yield


def test_covers_numpy_and_scipy_blas() -> None:
    paths = [i["filepath"] for i in blas_info()]
    assert any("numpy" in p for p in paths), paths
    assert any("scipy" in p for p in paths), paths


def test_inside_one_thread_and_restored_after(two_threads) -> None:
    assert counts() == [2] * len(counts())
    with frame_blas():
        assert set(counts()) == {1}
    assert set(counts()) == {2}
    with pytest.raises(RuntimeError), frame_blas():
        raise RuntimeError("boom")
    assert set(counts()) == {2}  # restored on an exception too


def test_nested_blocks_the_smallest_limit_holds(two_threads) -> None:
    with blas_limit(2):
        assert set(counts()) == {2}
        with frame_blas():
            assert set(counts()) == {1}
            with blas_limit(2), blas_limit(None):
                assert set(counts()) == {1}
        assert set(counts()) == {2}
    with blas_limit(3):  # at most: never above the count it found
        assert set(counts()) == {2}
    assert set(counts()) == {2}


def test_a_worker_thread_gets_its_limit(two_threads) -> None:
    # threadpoolctl's own setter acts only from the thread that first used it (this one)
    seen: list[list[int]] = []

    def work() -> None:
        with frame_blas():
            seen.append(counts())
        seen.append(counts())

    t = threading.Thread(target=work)
    t.start()
    t.join()
    assert set(seen[0]) == {1}
    assert set(seen[1]) == {2}


def test_set_frame_threads_and_its_errors(two_threads) -> None:
    assert frame_threads() == blas_threads.DEFAULT_FRAME_THREADS == 1
    try:
        set_frame_threads(None)
        with frame_blas():
            assert set(counts()) == {2}
        set_frame_threads(2)
        with frame_blas():
            assert set(counts()) == {2}
        for bad in (0, -1, True, 1.0, "1"):
            with pytest.raises(ValueError, match="threads must be an integer >= 1 or None"):
                set_frame_threads(bad)  # type: ignore[arg-type]
    finally:
        set_frame_threads(blas_threads.DEFAULT_FRAME_THREADS)
    assert frame_threads() == 1
