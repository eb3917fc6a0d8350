# Two commands on a fresh machine with nothing but Python:
#   make demo   run the main job: the quick benchmark suite (track bench) with its table
#   make test   run the whole default test suite (with the strict docs build)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.installed

.PHONY: demo test lint docs bench bench-check clean install

install: $(STAMP)

$(STAMP): pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	# torch: the pinned CPU build where it is available locally, else the registry's CPU build.
	$(PIP) install --quiet torch==2.13.0 || \
	  $(PIP) install --quiet torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu
	$(PIP) install --quiet -e ".[dev,torch,ray,rl]"
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/track bench run --suite quick --out results/quick

test: $(STAMP) lint
	MPLBACKEND=Agg SDL_VIDEODRIVER=dummy SDL_AUDIODRIVER=dummy $(PY) -m pytest -q

lint: $(STAMP)
	$(PY) -m ruff check track_envs predictors agents track_apps tests examples benchmarks
	$(PY) -m ruff format --check track_envs predictors agents track_apps tests examples benchmarks
	$(PY) -m mypy

# the docs site (site/); tests/test_docs.py builds it with --strict inside make test
docs: $(STAMP)
	$(VENV)/bin/mkdocs build --strict

bench: $(STAMP)
	$(PY) benchmarks/bench_belt_sorter.py
	$(PY) benchmarks/bench_belt_restore.py
	$(PY) benchmarks/bench_tracker.py
	$(PY) benchmarks/bench_metrics.py
	$(PY) benchmarks/bench_replay_load.py
	$(PY) benchmarks/bench_particle_filter.py
	$(PY) benchmarks/bench_keypoints.py
	$(PY) benchmarks/bench_runner_overhead.py
	$(PY) benchmarks/bench_lstm.py
	$(PY) benchmarks/bench_lstm_accuracy.py
	$(PY) benchmarks/bench_rendering.py
	$(PY) benchmarks/bench_track_run.py
	$(PY) benchmarks/bench_hota.py
	$(PY) benchmarks/bench_sensor_model.py
	$(PY) benchmarks/bench_jpda_marginals.py
	$(PY) benchmarks/bench_jpda.py
	$(PY) benchmarks/bench_pose_smc.py --threads 2
	$(PIP) install --quiet -e ".[compare]"
	$(PY) benchmarks/bench_scale.py --figure results/scale/scale.png
	$(PY) benchmarks/bench_existence.py

# performance floors: the same-run ratios behind the headline figures against benchmarks/floors.toml
# (a few minutes; not part of make test; run it before a change that touches a hot path)
bench-check: $(STAMP)
	MPLBACKEND=Agg $(PY) benchmarks/bench_check.py

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
	find track_envs predictors agents track_apps -name '*.nbi' -o -name '*.nbc' | xargs rm -f
