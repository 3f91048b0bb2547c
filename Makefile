# Quick start (fresh machine): `make benchmark` runs the paper protocol, `make test` runs the tests.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: benchmark test setup setup-test setup-bench lint

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

setup: $(BIN)/python
	$(BIN)/pip install --quiet .

setup-test: $(BIN)/python
	$(BIN)/pip install --quiet -e ".[test]"

# Speed benchmarks (benchmarks/speed/*.py) also need DEAP, Box2D and threadpoolctl: `make setup-bench`.
setup-bench: $(BIN)/python
	$(BIN)/pip install --quiet -e ".[test,bench]"

benchmark: setup
	$(BIN)/lfd-track benchmark --repetitions 10 --workers 2 --out results/paper

test: setup-test
	$(BIN)/python -m pytest -n 2 -q

lint: setup-test
	$(BIN)/pip install --quiet ruff
	$(BIN)/ruff check lfd_track tests benchmarks scripts
	$(BIN)/ruff format --check lfd_track tests benchmarks scripts
