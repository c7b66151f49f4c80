# Two commands do all the set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
# evtribo and what it needs to run (the demo's); the test, mf4 and dask extras beside it
STAMP  := $(VENV)/.installed
TEST_STAMP := $(VENV)/.test-installed
# pytest-xdist workers: three on two cores, so that the tests that wait on real time (a
# simulated rig's trials, a recording, a session) or on the SocketCAN VM leave no core idle
# (9 min 22 s on two idle cores against 10 min 19 s with two workers, the same CPU time)
JOBS   ?= 3
# the tests' Python processes (pytest's workers, the evtribo commands the tests start, the
# SocketCAN VM's) keep their compiled modules in __pycache__ (git ignores it) even where
# PYTHONDONTWRITEBYTECODE is set: each would otherwise compile evtribo and rewrite the test
# modules' asserts again; evtribo is compiled once before the workers and the VM start
TEST_ENV := PYTHONDONTWRITEBYTECODE=

.PHONY: demo test test-quick bench lint docs dist clean chromium vcan-vm

$(STAMP): pyproject.toml
	@echo "Setting up $(VENV): evtribo and the libraries it runs on (numpy, scipy, pandas,"
	@echo "matplotlib, statsmodels, python-can, cantools, pyarrow): about 2 minutes on the first"
	@echo "run, most of it downloading; pip says nothing while it installs them."
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --progress-bar off -e .
	@echo "$(VENV) is ready."
	touch $(STAMP)

# the test suite's libraries (pytest, hypothesis, the release's and the notebook's tools),
# asammdf (MDF 4) and dask, whose code the tests run too
$(TEST_STAMP): $(STAMP)
	@echo "Adding the test, mf4 and dask extras to $(VENV): a few more minutes the first time."
	$(PY) -m pip install --progress-bar off -e '.[test,mf4,dask]'
	touch $(TEST_STAMP)

demo: $(STAMP)
	$(VENV)/bin/evtribo demo --out demo-output --force

test: $(TEST_STAMP) chromium vcan-vm
	@$(PY) -m compileall -q src
	$(TEST_ENV) $(PY) -m pytest -n $(JOBS) -q

# headless Chromium (Debian's package) looks at the live view and the report in the tests;
# without it (not root, no apt) those tests are skipped and say why
chromium:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	{ if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; \
	  else echo "the tests that look at a page need Chromium (sudo apt-get install chromium); without it they are skipped"; fi; }

# a qemu VM whose kernel has SocketCAN (Debian's linux-image-amd64, downloaded, not installed)
# for the tests in tests/socketcan; without it (not root, no apt) they skip and say why
vcan-vm: $(TEST_STAMP)
	@missing=""; \
	command -v qemu-system-x86_64 >/dev/null 2>&1 || missing="$$missing qemu-system-x86"; \
	command -v canplayer >/dev/null 2>&1 || missing="$$missing can-utils"; \
	bb=$$(command -v busybox || true); \
	{ [ -n "$$bb" ] && ! grep -q ld-linux "$$bb"; } || missing="$$missing busybox-static"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
	  else echo "the SocketCAN tests need:$$missing (sudo apt-get install$$missing); without them they are skipped"; fi; \
	fi
	@$(PY) tests/_vcanvm.py prepare || echo "the SocketCAN tests will be skipped: no VM"

# the suite without the tests marked slow (real-time recordings across processes, coverage
# over many seeds, kill-at-every-step): for the edit-and-test loop; `make test` runs them all
test-quick: $(TEST_STAMP) chromium
	$(TEST_ENV) $(PY) -m pytest -n $(JOBS) -q -m "not slow"

bench: $(TEST_STAMP)
	for b in benchmarks/[!_]*.py; do $(PY) $$b || exit 1; done

lint: $(TEST_STAMP)
	$(PY) -m pip install --quiet -e '.[dev]'
	$(VENV)/bin/ruff check src tests benchmarks docs/conf.py
	$(VENV)/bin/mypy

# the documentation site, build/docs/html/index.html: Sphinx from docs/ (the README, every page,
# the API reference from the docstrings, the notebook executed), every warning an error (a
# broken link or anchor, a page out of the navigation, a docstring Sphinx cannot read, a
# failing cell); built afresh (-E), since an incremental build repeats no old warning
DOCS_STAMP := $(VENV)/.docs-installed
$(DOCS_STAMP): $(TEST_STAMP)
	$(PY) -m pip install --quiet -e '.[docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	rm -rf docs/generated build/docs
	$(VENV)/bin/sphinx-build -E -W --keep-going -q -b html -d build/docs/doctrees docs build/docs/html
	@echo "the documentation: build/docs/html/index.html"

# the release's files: dist/evtribo-<version>.tar.gz and the wheel, checked by twine
dist: $(TEST_STAMP)
	rm -rf dist
	$(PY) -m build --outdir dist
	$(VENV)/bin/twine check --strict dist/*

clean:
	rm -rf $(VENV) demo-output build dist docs/generated src/*.egg-info
