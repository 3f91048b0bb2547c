# Quick start (fresh machine): `make benchmark` runs the paper protocol, `make test` runs the tests.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# Exact versions of everything the setup targets install (pip, the build backend and every
# transitive dependency); pyproject.toml keeps open ranges for library users. `make lock` writes
# it anew; tests/package/test_lock.py fails when it no longer satisfies pyproject.toml.
LOCK := requirements.lock
LOCK_EXTRAS := test,bench
# PIP_BUILD_CONSTRAINT: the isolated build of the package takes the locked hatchling too.
PIP := PIP_CONSTRAINT="$(CURDIR)/$(LOCK)" PIP_BUILD_CONSTRAINT="$(CURDIR)/$(LOCK)" $(BIN)/python -m pip

.PHONY: benchmark test setup setup-test setup-bench lint lock

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

setup: $(BIN)/python
	$(PIP) install --quiet .

setup-test: $(BIN)/python
	$(PIP) install --quiet -e ".[test]"

# Speed benchmarks (benchmarks/speed/*.py) also need DEAP and Box2D: `make setup-bench`.
setup-bench: $(BIN)/python
	$(PIP) install --quiet -e ".[$(LOCK_EXTRAS)]"

# Resolve the newest releases that pyproject.toml allows, in a throwaway venv, and write them to
# $(LOCK) (pip freeze, less the project itself).
lock:
	@set -e; tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	$(PYTHON) -m venv "$$tmp/venv"; \
	"$$tmp/venv/bin/python" -m pip install --quiet --upgrade pip; \
	"$$tmp/venv/bin/python" -m pip install --quiet ".[$(LOCK_EXTRAS)]"; \
	{ echo "# Exact versions for the Makefile's setup targets (.[$(LOCK_EXTRAS)]), written by \`make lock\`"; \
	  echo "# with Python $$("$$tmp/venv/bin/python" -c 'import platform; print(platform.python_version())') on $$(uname -m). Do not edit by hand."; \
	  "$$tmp/venv/bin/python" -m pip freeze --all --exclude lfd-track; } > "$$tmp/lock.txt"; \
	mv "$$tmp/lock.txt" $(LOCK); echo "wrote $(LOCK)"

benchmark: setup
	$(BIN)/lfd-track benchmark --repetitions 10 --workers 2 --out results/paper

test: setup-test
	$(BIN)/python -m pytest -n 2 -q

lint: setup-test
	$(BIN)/ruff check lfd_track tests benchmarks scripts examples
	$(BIN)/ruff format --check lfd_track tests benchmarks scripts examples
	$(BIN)/mypy
