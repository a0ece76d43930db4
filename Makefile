# Set-up and the main jobs. Each target creates the virtual environment on first use.
PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin

.PHONY: demo test test-slow test-all lint docs bench study clean

$(BIN)/.installed: pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[fno,tune,test,docs]"
	touch $@

demo: $(BIN)/.installed  ## classical solvers on the five physical potentials: table + figure
	$(BIN)/nh-operators demo --out demo

test: $(BIN)/.installed  ## the test suite CI runs (slow checks skipped), on every core
	$(BIN)/python -m pytest -q -n auto

test-slow: $(BIN)/.installed  ## only the slow checks (CI's second step; about 10 minutes)
	$(BIN)/python -m pytest -q --runslow -m slow

test-all: $(BIN)/.installed  ## also the slow checks
	$(BIN)/python -m pytest -q --runslow

lint: $(BIN)/.installed  ## ruff and pyright (basic) on the package, as CI runs them
	$(BIN)/ruff check nh_operators
	$(BIN)/basedpyright --project pyproject.toml --pythonpath $(BIN)/python nh_operators

docs: $(BIN)/.installed  ## this site in docs/_build/html, warnings as errors; runs the tutorials (about a minute)
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

bench: $(BIN)/.installed  ## benchmark tables (minutes)
	$(BIN)/python benchmarks/cost/label_generation.py
	$(BIN)/python benchmarks/cost/classical_speed_accuracy.py
	$(BIN)/python benchmarks/cost/model_throughput.py

study: $(BIN)/.installed  ## work precision on the test set (minutes); add networks: make study RUNS="runs/a runs/b"
	test -f test.h5 || $(BIN)/nh-operators generate --preset test --out test.h5 --quiet
	$(BIN)/nh-operators benchmark --test test.h5 $(foreach r,$(RUNS),--run $(r)) --out bench

clean:
	rm -rf $(VENV) demo bench build *.egg-info
	rm -rf docs/_build docs/auto_examples docs/gen_modules docs/generated docs/sg_execution_times.rst
