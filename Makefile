# Two commands do all the set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
JOBS   ?= 2

.PHONY: demo test test-quick bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test,mf4]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/evtribo demo --out demo-output --force

test: $(STAMP)
	$(PY) -m pytest -n $(JOBS) -q

# the suite without the tests marked slow (real-time recordings across processes, coverage
# over many seeds, kill-at-every-step): for the edit-and-test loop; `make test` runs them all
test-quick: $(STAMP)
	$(PY) -m pytest -n $(JOBS) -q -m "not slow"

bench: $(STAMP)
	for b in benchmarks/*.py; do $(PY) $$b || exit 1; done

lint: $(STAMP)
	$(PY) -m pip install --quiet -e '.[dev]'
	$(VENV)/bin/ruff check src tests benchmarks
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV) demo-output build src/*.egg-info
