# The two set-up commands of the README (demo, test), and lint. Each creates .venv and installs
# mazeslam into it first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test lint bench install figures

$(BIN)/mazeslam: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	$(BIN)/python -m mazeslam.gridslam.precompile  # the grid filter's and the laser odometry's numba kernels, compiled once into the cache
	touch $(BIN)/mazeslam

install: $(BIN)/mazeslam

demo: install
	$(BIN)/mazeslam demo

test: install
	$(BIN)/pytest -n auto

# ruff (lint, then formatting) and mypy, configured in pyproject.toml.
LINTED := mazeslam tests benchmarks examples experiments

lint: install
	$(BIN)/ruff check $(LINTED)
	$(BIN)/ruff format --check $(LINTED)
	$(BIN)/mypy

bench: install
	$(BIN)/python benchmarks/run_all.py

# Every image docs/ and experiments/ show, remade from the code (scripts/make_docs_figures.py --list).
figures: install
	$(BIN)/python scripts/make_docs_figures.py
