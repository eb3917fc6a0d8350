"""Run cells, write one record per cell, skip finished cells; local and Ray engines.

A record is one JSON file in the out dir (name: [`Cell.filename`][track_apps.bench.Cell.filename], from a
stable hash of the cell)::

    {"schema": 1, "key": "<hash>", "cell": {...},
     "metrics": {"e1": ..., "mota": ..., ...},          # mean over the cell's episodes
     "episode_metrics": [{...}, ...],                  # only when episodes > 1
     "timing": {"wall_s": ..., "episode_s": ..., "frames": ..., "frames_per_s": ..., "host": ...},
     "versions": {"track-envs": ..., "numpy": ..., "gymnasium": ..., "pymunk": ...,
                  "track-envs-source": ..., "python": ...}}

Everything but ``"timing"`` depends only on the cell and the versions: the same seeds give the
same metrics on every engine. Non-finite metric values are stored as the strings ``"nan"``,
``"inf"``, ``"-inf"`` (strict JSON) and read back as floats.

Each record is written atomically by the driver process: a temporary file in the out dir, flushed
and fsynced, then ``os.replace`` d onto its name. A killed or interrupted run therefore leaves
only whole records, and a rerun with the same out dir computes just the cells without one.

Engines:
    ``local``: ``--workers 1`` runs the cells in this process; more workers use a
    ``concurrent.futures.ProcessPoolExecutor`` (forkserver processes, SIGINT ignored in the
    workers; Ctrl-C in the driver cancels the pending cells).
    ``ray``: one remote task per cell on ``ray.init()`` (a local instance) or
    ``ray.init(address=...)`` (a cluster; every node needs track-envs installed). Records
    come back to the driver, so the nodes need no shared file system.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import socket
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import agents
import predictors
import track_envs  # registers the environments
from agents import make_agent
from agents.episode import run_episode
from track_apps.bench.cells import NO_PREDICTOR, Cell
from track_apps.bench.progress import CellBar
from track_envs.infra.atomic import atomic_write
from track_envs.wrappers import TrackingMetrics

SCHEMA = 1
ENGINES = ("local", "ray")
RAY_HINT = 'the ray engine needs ray: pip install "track-envs[ray]" (or pip install "ray>=2.40")'


def source_digest(roots: list[Path]) -> str:
    """A short SHA-256 over every ``*.py`` file under ``roots`` (relative path and content), so
    that an edited checkout with an unchanged version number still counts as other code."""
    digest = hashlib.sha256()
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            digest.update(path.relative_to(root.parent).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


@cache
def versions() -> dict[str, str]:
    """Versions of the packages that decide a record's values, and a digest of this project's
    source (``track-envs-source``)."""
    out = {}
    for dist in ("track-envs", "numpy", "gymnasium", "pymunk"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = "not installed"
    packages = (track_envs, predictors, agents)
    out["track-envs-source"] = source_digest([Path(str(m.__file__)).parent for m in packages])
    out["python"] = platform.python_version()
    return out


def episode_seed(seed: int, episode: int) -> int:
    """Seed of episode ``episode`` of a cell: the cell's seed first, then derived ones."""
    if episode == 0:
        return seed
    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def _json_float(value: Any) -> float | str:
    value = float(value)
    return value if math.isfinite(value) else str(value)


def make_env(cell: Cell) -> gym.Env:
    """The cell's env wrapped in [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics]."""
    kwargs = dict(cell.env_kwargs)
    if cell.steps is not None:
        kwargs["max_episode_steps"] = cell.steps
    return TrackingMetrics(gym.make(cell.env_id, **kwargs))


def make_cell_agent(cell: Cell) -> Any:
    """The cell's agent (with its predictor, if it takes one, and its agent kwargs)."""
    kwargs = dict(cell.agent_kwargs)
    if cell.predictor != NO_PREDICTOR:
        kwargs["predictor"] = cell.predictor
    return make_agent(cell.agent, **kwargs)


class CellError(ValueError):
    """A cell whose env or agent cannot be built; the message is one line naming the cell."""


def describe_cell(cell: Cell) -> str:
    """``BeltSorter-v0 [noise_std=abc, steps=100] gnn/kf-ca seed 0``: a cell in one line."""
    params = ", ".join(f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}" for k, v in cell.params())
    agent = cell.agent if cell.predictor == NO_PREDICTOR else f"{cell.agent}/{cell.predictor}"
    return f"{cell.env_id} [{params or 'defaults'}] {agent} seed {cell.seed}"


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "(no message)"
    return f"{type(exc).__name__}: {text}"


def check_cells(cells: Iterable[Cell]) -> int:
    """Build every distinct env and agent of ``cells`` once, reset them and close them.

    An env is distinct by (env id, env kwargs, steps), an agent by (agent, predictor, agent
    kwargs); each agent is reset with the sensor spec of the first env it runs on. Run before
    the first cell, this turns a bad argument (``noise_std="abc"``, ``noise_std=-1``, an agent
    kwarg the agent does not take) into one error before any work is done, instead of a
    traceback from a worker after other cells ran.

    Returns:
        The number of distinct argument sets checked (envs plus agents).

    Raises:
        CellError: for the first cell whose env or agent raises, naming the cell and the error.
    """
    specs: dict[tuple[Any, ...], Any] = {}
    agents_seen: set[tuple[Any, ...]] = set()
    for cell in cells:
        env_key = (cell.env_id, cell.env_kwargs, cell.steps)
        if env_key not in specs:
            try:
                env = make_env(cell)
                try:
                    env.reset(seed=cell.seed)
                    specs[env_key] = env.get_wrapper_attr("sensor_spec")
                finally:
                    env.close()
            except Exception as exc:
                raise CellError(f"cell {describe_cell(cell)}: env: {_one_line(exc)}") from exc
        agent_key = (cell.agent, cell.predictor, cell.agent_kwargs)
        if agent_key not in agents_seen:
            try:
                make_cell_agent(cell).reset(specs[env_key], seed=cell.seed)
            except Exception as exc:
                raise CellError(f"cell {describe_cell(cell)}: agent: {_one_line(exc)}") from exc
            agents_seen.add(agent_key)
    return len(specs) + len(agents_seen)


def run_cell(cell: Cell) -> dict[str, Any]:
    """Run every episode of ``cell``; return its record (see the module docstring)."""
    start = time.perf_counter()
    env = make_env(cell)
    agent = make_cell_agent(cell)
    episodes, frames, episode_s = [], 0, 0.0
    try:
        for k in range(cell.episodes):
            t0 = time.perf_counter()
            result = run_episode(env, agent, seed=episode_seed(cell.seed, k))
            episode_s += time.perf_counter() - t0
            episodes.append(result.metrics)
            frames += result.frames
    finally:
        env.close()
    wall = time.perf_counter() - start
    keys = list(dict.fromkeys(k for m in episodes for k in m))
    mean = {k: _json_float(np.mean([m.get(k, np.nan) for m in episodes])) for k in keys}
    record: dict[str, Any] = {"schema": SCHEMA, "key": cell.key, "cell": cell.to_dict(), "metrics": mean}
    if cell.episodes > 1:
        record["episode_metrics"] = [{k: _json_float(v) for k, v in m.items()} for m in episodes]
    record["timing"] = {
        "wall_s": wall,
        "episode_s": episode_s,
        "frames": frames,
        "frames_per_s": frames / episode_s if episode_s > 0 else float("nan"),
        "host": socket.gethostname(),
    }
    record["versions"] = versions()
    return record


def write_record(out_dir: str | os.PathLike[str], record: dict[str, Any]) -> Path:
    """Write ``record`` atomically ([`track_envs.infra.atomic.atomic_write`][track_envs.io.atomic_write]: a
    temporary file in ``out_dir``, fsync, ``os.replace``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = out / Cell.from_dict(record["cell"]).filename
    with atomic_write(target) as fh:
        json.dump(record, fh, indent=1, allow_nan=False)
    return target


class RecordError(ValueError):
    """A file in an out dir that is not a readable record of this schema."""


class SkippedRecordWarning(UserWarning):
    """[`load_records`][track_apps.bench.load_records] left a file out (the message names it and says why)."""


def read_record(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A record from its file, with non-finite metric strings turned back into floats.

    Raises:
        RecordError: the file is not JSON, not a record, of another schema, or its cell or
            metrics are malformed; the message says which.
    """
    try:
        with open(path) as fh:
            record = json.load(fh)
    except UnicodeDecodeError as exc:
        raise RecordError(f"not text: {exc}") from exc
    except json.JSONDecodeError as exc:
        raise RecordError(f"not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from exc
    if not isinstance(record, dict) or "schema" not in record:
        raise RecordError("not a track bench record (no 'schema' key)")
    if record["schema"] != SCHEMA:
        raise RecordError(f"record schema {record['schema']!r}, this version reads schema {SCHEMA}")
    missing = [k for k in ("key", "cell", "metrics") if k not in record]
    if missing:
        raise RecordError(f"record without {', '.join(map(repr, missing))}")
    try:
        cell = Cell.from_dict(record["cell"])
        record["metrics"] = {k: float(v) for k, v in record["metrics"].items()}
        if "episode_metrics" in record:
            record["episode_metrics"] = [
                {k: float(v) for k, v in m.items()} for m in record["episode_metrics"]
            ]
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise RecordError(f"malformed cell or metrics ({_one_line(exc)})") from exc
    if cell.key != record["key"]:
        raise RecordError(f"key {record['key']!r} does not match its cell (key {cell.key!r})")
    return record


@dataclass(frozen=True)
class RecordScan:
    """What [`scan_records`][track_apps.bench.runner.scan_records] found: the records and the skipped files
    with the reason."""

    records: list[dict[str, Any]]
    skipped: list[tuple[Path, str]]


def scan_records(out_dir: str | os.PathLike[str]) -> RecordScan:
    """Every record in ``out_dir`` sorted by file name, and every other ``*.json`` with the reason
    it is not one (temporary ``.tmp-*.part`` files of a running write are not ``*.json``)."""
    records, skipped = [], []
    for path in sorted(Path(out_dir).glob("*.json")):
        try:
            records.append(read_record(path))
        except (OSError, RecordError) as exc:
            skipped.append((path, str(exc)))
    return RecordScan(records, skipped)


def load_records(out_dir: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every record in ``out_dir``, sorted by file name.

    Each ``*.json`` file that is not a readable record is left out with a
    `SkippedRecordWarning` naming it and the reason (see
    `scan_records`).
    """
    scan = scan_records(out_dir)
    for path, reason in scan.skipped:
        warnings.warn(f"skipped {path}: {reason}", SkippedRecordWarning, stacklevel=2)
    return scan.records


def is_finished(out_dir: Path, cell: Cell) -> bool:
    """Whether ``out_dir`` holds a whole record of ``cell`` made by this schema and these versions.

    A record from other package versions is stale: the cell is computed again and its record
    overwritten, so a table never mixes results of different code.
    """
    path = out_dir / cell.filename
    if not path.exists():
        return False
    try:
        record = read_record(path)
    except (OSError, RecordError):
        return False
    return bool(record["key"] == cell.key and record.get("versions") == versions())


@dataclass(frozen=True)
class RunResult:
    """What [`run_cells`][track_apps.bench.run_cells] did."""

    total: int
    computed: int
    skipped: int
    wall_s: float
    out_dir: Path


OnRecord = Callable[[dict[str, Any]], None]


def _ignore_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local_engine(cells: Sequence[Cell], workers: int, on_record: OnRecord) -> None:
    if workers <= 1 or len(cells) <= 1:
        for cell in cells:
            on_record(run_cell(cell))
        return
    import multiprocessing as mp

    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["track_apps.bench.runner"])
    pool = ProcessPoolExecutor(min(workers, len(cells)), mp_context=ctx, initializer=_ignore_sigint)
    pending: set[Future[dict[str, Any]]] = {pool.submit(run_cell, cell) for cell in cells}
    try:
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                on_record(future.result())
    except BaseException:
        for future in pending:
            future.cancel()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _ray_engine(cells: Sequence[Cell], address: str | None, on_record: OnRecord) -> None:
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError(RAY_HINT) from exc
    started = not ray.is_initialized()
    if started:
        ray.init(address=address) if address else ray.init()
    remote = ray.remote(num_cpus=1)(run_cell)
    pending = {remote.remote(cell): cell for cell in cells}
    try:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                pending.pop(ref)
                on_record(ray.get(ref))
    except BaseException:
        for ref in pending:
            ray.cancel(ref)
        raise
    finally:
        if started:
            ray.shutdown()


def run_cells(
    cells: Iterable[Cell],
    out_dir: str | os.PathLike[str],
    *,
    engine: str = "local",
    workers: int | None = None,
    address: str | None = None,
    progress: bool = True,
    check: bool = True,
) -> RunResult:
    """Run every cell of ``cells`` that has no record in ``out_dir`` yet and write its record.

    Args:
        cells: The cells (see [`track_apps.bench.cells.expand`][track_apps.bench.expand]).
        out_dir: Directory of the records (created if missing).
        engine: ``"local"`` (process pool, or in-process with ``workers=1``) or ``"ray"``.
        workers: Local processes (default: the CPU count); ignored by ``"ray"``.
        address: Ray cluster address (``ray.init(address=...)``); ``None`` starts a local Ray.
        progress: Show a tqdm bar over the cells (its time left leaves out each worker's first
            cell, which compiles the kernels:
            `track_apps.bench.progress.CellBar`).
        check: Build every distinct env and agent of the cells to run first
            (`check_cells`), so a bad argument stops the run before any
            cell ran.

    Returns:
        Counts of computed and skipped cells and the wall time.

    Raises:
        CellError: (with ``check``) a cell's env or agent cannot be built; nothing ran.
    """
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; valid names are {list(ENGINES)}")
    start = time.perf_counter()
    out = Path(out_dir)
    cells = list(cells)
    todo = [c for c in cells if not is_finished(out, c)]
    if check:
        check_cells(todo)
    out.mkdir(parents=True, exist_ok=True)
    n_workers = workers or os.cpu_count() or 1
    # the first cell of each worker compiles the kernels: its time is left out of the ETA
    parallel = n_workers if engine == "local" else os.cpu_count() or 1
    bar = CellBar(
        total=len(todo),
        unit="cell",
        desc=f"track bench ({engine})",
        disable=not progress,
        warm_up=max(1, min(parallel, len(todo))),
    )

    def on_record(record: dict[str, Any]) -> None:
        write_record(out, record)
        bar.update()

    try:
        if engine == "ray":
            _ray_engine(todo, address, on_record)
        else:
            _local_engine(todo, n_workers, on_record)
    finally:
        bar.close()
    return RunResult(len(cells), len(todo), len(cells) - len(todo), time.perf_counter() - start, out)
