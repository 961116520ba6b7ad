# Two commands on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: run test test-slow test-all bench clean

# pip byte-compiles at install (3-3.5 min on 2 cores; --no-compile takes 1.5 min, but where
# PYTHONDONTWRITEBYTECODE is set, as in this workplace's shells, every process would compile its imports again:
# benchmarks/README.md, "The default district build")
$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	# torch first, pinned: the CPU build on this machine; an open range would pull a CUDA build.
	$(PY) -m pip install -q torch==2.13.0
	# every extra: the pipeline, surrogates, RL, Dask, EnergyPlus, FMU, numba and the test tools
	$(PY) -m pip install -q -e ".[all]"
	touch $(STAMP)

# Prefect runs with no server (ephemeral); quiet and patient on a 2-core machine
PREFECT_ENV := PREFECT_SERVER_ANALYTICS_ENABLED=false PREFECT_LOGGING_LEVEL=WARNING \
	PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS=180

run: $(STAMP)
	$(PREFECT_ENV) $(PY) -m pipeline.cli build raw/district.toml

test: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m pytest -q -n 2 --durations=15

test-slow: $(STAMP)
	$(PY) -m pytest -q -n 2 -m slow

test-all: $(STAMP)
	$(PY) -m pytest -q -n 2 -m "slow or not slow"

bench: $(STAMP)
	$(PY) benchmarks/env_speed.py

clean:
	rm -rf $(VENV) artifacts/*/
