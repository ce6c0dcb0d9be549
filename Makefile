# Quick start: `make run` and `make test`. Both create .venv and install into it when needed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
INSTALL_INPUTS := pyproject.toml setup.py MANIFEST.in rtcore/_build.py firmware_profiles/__init__.py \
                  $(wildcard csrc/*.c csrc/*.h)

.PHONY: run test test-install bench lint clean

$(STAMP): $(INSTALL_INPUTS)
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip setuptools wheel cffi
	$(PY) -m pip install --quiet --no-build-isolation --editable '.[test]'
	@touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/hand-service run --demo

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q -m "not slow and not install"

# a wheel of the checkout, installed in a fresh venv outside it, runs (about 10 s)
test-install: $(STAMP)
	$(PY) -m pytest -q -m install

bench: $(STAMP)
	$(VENV)/bin/hand-service bench --json bench.json
	$(PY) -m pytest -q tests/bench --benchmark-enable --benchmark-only
	$(PY) -m pytest -q -m slow

lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) build *.egg-info rtcore/_rtcore.c rtcore/*.so csrc/*.o
