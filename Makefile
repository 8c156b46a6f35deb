# Two commands on a fresh machine:
#   make run    set up the venv and run the paper's study with the embedded runner
#   make test   what CI runs (.ci/run, with CI=true): set up the venv, lint (ruff), type-check
#               every module but the ROS adapters, the pure cores strictly (mypy), install the firmware's Debian tools, the browser
#               tests' tools and iproute2 if missing (make firmware-tools browser-tools
#               system-tools), run every test on
#               TEST_JOBS parallel workers (tests/README.md)
# and one for the inner loop:
#   make check  lint, type-check and the unit tests (no ROS, no tools), in parallel
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PACKAGES := src/mona_controller src/swarm_world src/swarm_metrics src/swarm_supervisor
STUDY_OUT ?= results/study
# Python writes its bytecode (__pycache__, ignored by git) even where the environment says not
# to (PYTHONDONTWRITEBYTECODE=1, as the machine we measure on sets it): else every process the
# tests start compiles the project's modules again (a clean clone: the world node's imports
# 0.97 -> 0.72 CPU-s, the metrics node's 1.24 -> 0.85, pytest's collection 9.8 -> 4.8).
export PYTHONDONTWRITEBYTECODE :=

.PHONY: venv run test test-setup check lint typecheck bench sensitivity clean firmware-tools \
	firmware browser-tools system-tools conformance

venv: $(VENV)/.warmed

# uv (from PyPI, pinned) installs the pinned libraries and the four packages (editable) into
# the venv: it downloads in parallel and compiles no bytecode (Python compiles and caches the
# modules imported, on first import). 2026-12-05, a new venv with no download cache: pip 45 s
# (--no-compile; 77 s with), uv 15 s. The venv keeps its own pip (test_installed uses it).
UV_VERSION := 0.13.9
$(VENV)/.installed: requirements.txt $(foreach p,$(PACKAGES),$(p)/setup.py)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet uv==$(UV_VERSION)
	$(VENV)/bin/uv pip install --quiet --python $(PY) -r requirements.txt \
		$(foreach p,$(PACKAGES),-e $(p))
	touch $@

# Fill numba's cache in one process, before make run or make test start processes side by side
# (docs/architecture.md "Numba's cache"; 42 s on a fresh clone). Lint and types need only the
# installed venv, so make test runs them beside it.
$(VENV)/.warmed: $(VENV)/.installed
	$(PY) -m swarm_supervisor.engine.warm
	touch $@

run: venv
	$(VENV)/bin/mona-swarm study --out $(STUDY_OUT)

# pytest-xdist workers: more than the cores, since many tests wait on processes, the clock
# or a browser rather than compute (tests/README.md). On 2 cores, from a clean clone
# with no caches (2026-12-05): 11.6 - 11.8 min wall idle (pytest 660 - 668 s), 15.5 min (pytest
# 853 - 858 s) under ../shared/tools/under-load.
# 6 workers were slower idle (16.5 min, pytest 898 s, the same commit); 5 no faster (pytest
# 861 s against 855 s with 4, one venv); 3 slower (pytest 706 s against 686 s, 4.4 % idle).
TEST_JOBS ?= 4
test: test-setup
	MONA_SWARM_FOXGLOVE_CACHE='$(FOXGLOVE_CACHE)' $(PY) -m pytest -n $(TEST_JOBS)

# make test's steps before the tests, side by side (numba's warm-up beside lint and types, all
# beside the Debian packages and npm; each step's output printed whole when it ends). On a new
# machine with none of the tools and no caches: 1.4 min, downloads included (README).
test-setup:
	@$(MAKE) --no-print-directory -j6 -Otarget venv lint typecheck firmware-tools \
		browser-tools system-tools

check: venv lint typecheck
	$(PY) -m pytest tests/unit -q -n $(TEST_JOBS)

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check .

# The types of every module but the ROS adapters, the pure cores strictly (folder rules:
# pyproject.toml, [tool.mypy])
typecheck: $(VENV)/.installed
	$(VENV)/bin/mypy

# The sensitivity design of docs/model.md (180 episodes of 4000 s; resumes a partial run)
sensitivity: venv
	$(VENV)/bin/mona-swarm study --config ros_ws/config/designs/sensitivity.yaml \
		--out results/sensitivity

# The tools make test needs beyond the venv, each in its own target (tests/install-tools.sh):
# the firmware's Debian toolchain and simulator (docs/link.md), and the browser tests' Debian
# chromium and Foxglove web build (docs/bags.md: npm, @foxglove/studio-base 1.48.0 and React 17
# as tests/browser/app/package-lock.json pins them, into FOXGLOVE_CACHE, outside the checkout;
# reinstalled when package.json or the lock changes). Quick when present (0.1 s). Under CI=true
# a tool installs or the target fails naming the command that failed and the tail of its
# output; elsewhere (no root) it only says so, the tests needing it skip, and make test ends
# with a banner listing them.
FOXGLOVE_CACHE ?= $(or $(MONA_SWARM_FOXGLOVE_CACHE),$(HOME)/.cache/mona-swarm/foxglove)
firmware-tools:
	@tests/install-tools.sh firmware

browser-tools:
	@FOXGLOVE_CACHE='$(FOXGLOVE_CACHE)' tests/install-tools.sh browser

# iproute2's ip, for the node system across two network namespaces (tests/system/test_netns.py)
system-tools:
	@tests/install-tools.sh system

# The classic Mona's firmware image (firmware/mona/mona.elf, mona.hex) and its simavr host
# (firmware/sim/monasim); docs/link.md
firmware: firmware-tools
	$(MAKE) -C firmware/mona
	$(MAKE) -C firmware/sim

# docs/interfaces.md as tests against a world-side implementation (make test runs it on the
# world node): WORLD is a name of tests/conformance/implementations.py or a command line
WORLD ?= world
conformance: venv
	$(PY) -m pytest tests/conformance -q --world-cmd '$(WORLD)'

bench: venv
	$(PY) bench/bench_embedded.py

clean:
	rm -rf $(VENV) results .pytest_cache
	-$(MAKE) -s -C firmware/mona clean
	-$(MAKE) -s -C firmware/sim clean
