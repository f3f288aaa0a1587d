# fsph: the README's two commands.
#   make run   set up what is missing, build, run the default Taylor-rod case
#   make test  set up what is missing, build, run the test suite (CI)
# Other targets: make bench (benchmark suite, docs/performance.md), make docs (deck reference),
# make test-slow (long studies), make clean.

PYTHON ?= python3
VENV ?= .venv
VPY := $(VENV)/bin/python
STAMP := $(VENV)/.fsph-installed
SOURCES := $(wildcard src_f90/*.f90 src_f90/.f2py_f2cmap fsph/*.py) meson.build meson.options pyproject.toml
DECK ?= cases/taylor_armco.nml
# test processes (pytest-xdist); each test file runs whole in one of them, so
# a file's module fixtures (the validation runs) run once; each process's runs
# take the threads the adaptive thread policy finds free
TEST_WORKERS ?= 2
OUT ?= out/$(basename $(notdir $(DECK)))

.PHONY: run test test-slow bench docs toolchain clean

toolchain:
	@PYTHON=$(PYTHON) ./scripts/bootstrap.sh

$(VPY): | toolchain
	$(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip

# regular (non-editable) install with pip's build isolation: the build
# environment lives outside the source tree, which meson requires
$(STAMP): $(SOURCES) | $(VPY)
	$(VPY) -m pip install -q '.[test]'
	touch $@

run: toolchain $(STAMP)
	$(VENV)/bin/fsph run $(DECK) -o $(OUT)

test: toolchain $(STAMP)
	$(VENV)/bin/pytest -m "not slow" -n $(TEST_WORKERS) --dist loadfile

test-slow: toolchain $(STAMP)
	$(VENV)/bin/pytest -m slow -n $(TEST_WORKERS) --dist loadfile

# the benchmark suite (docs/performance.md); BENCH_ARGS=--quick for a short run
bench: toolchain $(STAMP)
	$(VPY) benchmarks/suite.py --json docs/performance.json $(BENCH_ARGS)

docs: toolchain $(STAMP)
	$(VENV)/bin/fsph decks-reference -o docs/decks.md

clean:
	rm -rf $(VENV) build out .pytest_cache
