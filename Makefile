# Two commands on a fresh machine with Python 3.11 and make:
#   make demo   create .venv, install everything, run the default scenario, print where its figures are
#   make test   create .venv if needed, install the test extras, lint, run the whole suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
DEMO_OUT := runs/demo

.PHONY: demo test test-all lint clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

$(VENV)/.installed-all: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[all]"
	touch $@ $(VENV)/.installed-test

demo: $(VENV)/.installed-all
	$(BIN)/neuronav run path-integration --trials 20 --out $(DEMO_OUT)
	@echo "figures: $$(ls $(DEMO_OUT)/*.png | tr '\n' ' ')"

lint: $(VENV)/.installed-test
	$(BIN)/ruff check .

# The suite without the long validation runs (their short variants still run).
test: lint
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m "not slow" tests

# Everything, the long runs included.
test-all: lint
	MPLBACKEND=Agg $(BIN)/python -m pytest -q tests

clean:
	rm -rf $(VENV) runs .pytest_cache
