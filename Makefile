# Two commands on a fresh machine:
#   make run    set up the venv and run the paper's study with the embedded runner
#   make test   set up the venv, lint (ruff), type-check the pure cores (mypy), install the
#               firmware's Debian tools and the browser tests' tools if missing
#               (make firmware-tools browser-tools), run the tests
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PACKAGES := src/mona_controller src/swarm_world src/swarm_metrics src/swarm_supervisor
STUDY_OUT ?= results/study

.PHONY: venv run test lint typecheck bench sensitivity clean firmware-tools firmware \
	browser-tools conformance test-extended

venv: $(VENV)/.installed

$(VENV)/.installed: requirements.txt $(foreach p,$(PACKAGES),$(p)/setup.py)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	$(PY) -m pip install --quiet $(foreach p,$(PACKAGES),-e $(p))
	touch $@

run: venv
	$(VENV)/bin/mona-swarm study --out $(STUDY_OUT)

test: lint typecheck firmware-tools browser-tools
	$(PY) -m pytest

# The extended tier (not in make test or CI): other forms of tests make test runs once
# (pyproject.toml's 'extended' marker), e.g. SIGTERM 20 s into a 60-robot start-up
test-extended: venv firmware-tools
	$(PY) -m pytest -m extended

lint: venv
	$(VENV)/bin/ruff check .

# The pure cores' types (the files: pyproject.toml, [tool.mypy])
typecheck: venv
	$(VENV)/bin/mypy

# The sensitivity design of docs/model.md (180 episodes of 4000 s; resumes a partial run)
sensitivity: venv
	$(VENV)/bin/mona-swarm study --config ros_ws/config/designs/sensitivity.yaml \
		--out results/sensitivity

# The firmware's toolchain and simulator (docs/link.md), from Debian (the firmware tests need
# them; nothing installed by hand survives to the next machine). Quick when present
# (dpkg-query only, 0.1 s) and soft: without dpkg, root (or sudo -n) or apt-get's success it
# only says so, and the firmware tests skip naming the missing tool, so make test goes on.
FIRMWARE_TOOLS := gcc-avr avr-libc simavr libsimavr-dev libsimavrparts1 libelf-dev pkg-config
firmware-tools:
	@command -v dpkg-query >/dev/null || \
		{ echo "firmware-tools: no dpkg; install $(FIRMWARE_TOOLS) by hand"; exit 0; }; \
	missing=$$(for p in $(FIRMWARE_TOOLS); do \
		dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; \
	done); \
	missing=$$(echo $$missing); \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ]; then sudo=; \
	elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo='sudo -n'; \
	else echo "firmware-tools: missing $$missing (not root: the firmware tests will skip)"; exit 0; \
	fi; \
	apt="$$sudo env DEBIAN_FRONTEND=noninteractive apt-get"; \
	echo "firmware-tools: apt-get install $$missing"; \
	{ $$apt install -y --no-install-recommends $$missing >/dev/null 2>&1 || \
	  { $$apt update -qq >/dev/null 2>&1 && \
	    $$apt install -y --no-install-recommends $$missing >/dev/null 2>&1; }; } || \
	echo "firmware-tools: apt-get failed; the firmware tests will skip"

# The browser tests' tools (docs/bags.md, "The layout in a real browser"): Debian's chromium (Playwright drives it:
# requirements.txt pins playwright, which downloads no browser of its own) and the Foxglove web
# build from npm, @foxglove/studio-base 1.48.0 with React 17 as tests/browser/app/
# package-lock.json pins them, into a cache OUTSIDE the checkout (FOXGLOVE_CACHE; the tests
# read MONA_SWARM_FOXGLOVE_CACHE, same default). Quick when present (dpkg-query and a cmp of
# the lock, 0.1 s) and soft like firmware-tools: what cannot be installed is only reported,
# and the browser tests skip naming it.
BROWSER_TOOLS := chromium fonts-dejavu-core
FOXGLOVE_CACHE ?= $(or $(MONA_SWARM_FOXGLOVE_CACHE),$(HOME)/.cache/mona-swarm/foxglove)
FOXGLOVE_APP := tests/browser/app
browser-tools:
	@command -v dpkg-query >/dev/null || \
		{ echo "browser-tools: no dpkg; install $(BROWSER_TOOLS) by hand"; exit 0; }; \
	missing=$$(for p in $(BROWSER_TOOLS); do \
		dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; \
	done); \
	missing=$$(echo $$missing); \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ]; then sudo=; \
	elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo='sudo -n'; \
	else echo "browser-tools: missing $$missing (not root: the browser tests will skip)"; exit 0; \
	fi; \
	apt="$$sudo env DEBIAN_FRONTEND=noninteractive apt-get"; \
	echo "browser-tools: apt-get install $$missing"; \
	{ $$apt install -y --no-install-recommends $$missing >/dev/null 2>&1 || \
	  { $$apt update -qq >/dev/null 2>&1 && \
	    $$apt install -y --no-install-recommends $$missing >/dev/null 2>&1; }; } || \
	echo "browser-tools: apt-get failed; the browser tests will skip"
	@cache='$(FOXGLOVE_CACHE)'; \
	if cmp -s $(FOXGLOVE_APP)/package-lock.json "$$cache/.installed-lock.json"; then exit 0; fi; \
	command -v npm >/dev/null || \
		{ echo "browser-tools: no npm; the browser tests will skip"; exit 0; }; \
	echo "browser-tools: npm ci @foxglove/studio-base into $$cache"; \
	mkdir -p "$$cache" && \
	cp $(FOXGLOVE_APP)/package.json $(FOXGLOVE_APP)/package-lock.json "$$cache/" && \
	( cd "$$cache" && npm ci --no-audit --no-fund --loglevel=error >/dev/null 2>&1 ) && \
	cp $(FOXGLOVE_APP)/package-lock.json "$$cache/.installed-lock.json" || \
	echo "browser-tools: npm ci failed; the browser tests will skip"

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
