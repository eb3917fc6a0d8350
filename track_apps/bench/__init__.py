"""The benchmark runner behind ``track bench`` (also ``python -m track_apps.bench``).

Runs agents × predictors × envs × seeds as cells, one atomically written JSON record per cell,
on a local process pool (default) or Ray, and builds tables and plots from the records::

    from track_apps.bench import expand, load_suite, run_cells, load_records, write_tables
    cells = expand(load_suite("quick"))
    run_cells(cells, "results/quick", workers=2)
    write_tables(load_records("results/quick"), "results/quick")
"""

from __future__ import annotations

from track_apps.bench.cells import NO_PREDICTOR, Cell, Group, expand, load_suite, plan, suite_names
from track_apps.bench.runner import load_records, run_cell, run_cells, write_record
from track_apps.bench.tables import aggregate, terminal_table, write_tables
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
