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

# The ant walks home on MuJoCo (3 embodied homing trials, a video of the first), then Stone et
# al. 2017's 1000 point agents home in one batch on the kinematic backend.
demo: $(VENV)/.installed-all
	MUJOCO_GL=egl $(BIN)/neuronav run path-integration --backend mujoco --trials 3 --video --report --out $(DEMO_OUT)
	$(BIN)/neuronav run path-integration --trials 1000 --out $(DEMO_OUT)-stone2017
	@echo "video: $(DEMO_OUT)/trial0.mp4"
	@echo "report (open it in a browser): $(DEMO_OUT)/report.html"
	@echo "figures: $$(ls $(DEMO_OUT)/*.png $(DEMO_OUT)-stone2017/*.png | tr '\n' ' ')"

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
