# Two commands do all the set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
JOBS   ?= 2

.PHONY: demo test test-quick bench lint clean chromium

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,mf4,dask]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/evtribo demo --out demo-output --force

test: $(STAMP) chromium
	$(PY) -m pytest -n $(JOBS) -q

# headless Chromium (Debian's package) looks at the live view in the tests
chromium:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	{ if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; \
	  else echo "the live view's tests need Chromium: sudo apt-get install chromium"; exit 1; fi; }

# the suite without the tests marked slow (real-time recordings across processes, coverage
# over many seeds, kill-at-every-step): for the edit-and-test loop; `make test` runs them all
test-quick: $(STAMP) chromium
	$(PY) -m pytest -n $(JOBS) -q -m "not slow"

bench: $(STAMP)
	for b in benchmarks/[!_]*.py; do $(PY) $$b || exit 1; done

lint: $(STAMP)
	$(PY) -m pip install --quiet -e '.[dev]'
	$(VENV)/bin/ruff check src tests benchmarks
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV) demo-output build src/*.egg-info
