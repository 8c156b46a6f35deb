# Two commands on a fresh machine:
#   make run    set up the venv and run the paper's study with the embedded runner
#   make test   set up the venv, lint (ruff) and run the test suite
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PACKAGES := src/mona_controller src/swarm_world src/swarm_metrics src/swarm_supervisor
STUDY_OUT ?= results/study

.PHONY: venv run test lint bench clean

venv: $(VENV)/.installed

$(VENV)/.installed: requirements.txt $(foreach p,$(PACKAGES),$(p)/setup.py)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	$(PY) -m pip install --quiet $(foreach p,$(PACKAGES),-e $(p))
	touch $@

run: venv
	$(VENV)/bin/mona-swarm study --out $(STUDY_OUT)

test: lint
	$(PY) -m pytest

lint: venv
	$(VENV)/bin/ruff check .

bench: venv
	$(PY) bench/bench_embedded.py

clean:
	rm -rf $(VENV) results .pytest_cache
