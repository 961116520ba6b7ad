# Two commands on a fresh machine: `make run` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
RUN_STAMP := $(VENV)/.run-stamp
STAMP  := $(VENV)/.installed-stamp

.PHONY: run test test-slow test-all bench clean

# pip installs without byte-compiling, then compileall compiles on every core (pip's own compiling is serial:
# benchmarks/README.md, "The default district build"). The modules must be compiled in the venv: where
# PYTHONDONTWRITEBYTECODE is set, as in this workplace's shells, Python would otherwise compile them again in
# every process. compileall's status is not checked: a few packages ship files for newer Pythons that do not
# compile here (pip skips them the same way).
PIP_INSTALL := $(PY) -m pip install -q --no-compile
COMPILE     := $(PY) -m compileall -q -j 0 $(VENV)/lib > /dev/null 2>&1 || true

# `make run`: torch and what a build needs (the pipeline, EnergyPlus)
$(RUN_STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP_INSTALL) --upgrade pip
	# torch first, pinned: the CPU build on this machine; an open range would pull a CUDA build.
	$(PIP_INSTALL) torch==2.13.0
	$(PIP_INSTALL) -e ".[pipeline,energyplus]"
	$(COMPILE)
	touch $@

# `make test`: every extra (RL, Dask, FMU, numba, JAX's SAC, the test tools) on top
$(STAMP): $(RUN_STAMP)
	$(PIP_INSTALL) -e ".[all]"
	$(COMPILE)
	touch $@

# Prefect runs with no server (ephemeral); quiet and patient on a 2-core machine
PREFECT_ENV := PREFECT_SERVER_ANALYTICS_ENABLED=false PREFECT_LOGGING_LEVEL=WARNING \
	PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS=180

run: $(RUN_STAMP)
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
