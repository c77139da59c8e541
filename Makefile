# The two set-up commands of the README. Each creates .venv and installs mazeslam into it first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test bench install

$(BIN)/mazeslam: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(BIN)/mazeslam

install: $(BIN)/mazeslam

demo: install
	$(BIN)/mazeslam demo

test: install
	$(BIN)/pytest -n auto

bench: install
	$(BIN)/python benchmarks/run_all.py
