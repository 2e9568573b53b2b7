# nurimc — entry point. `make demo` runs the main job; `make test` installs and runs every test.
SHELL := /bin/bash
.DEFAULT_GOAL := help
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

help:  ## list the targets
	@grep -E '^[a-z-]+:.*##' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | column -t -s $$'\t'

$(STAMP): python/pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e "python[dev]"
	touch $(STAMP)

venv: $(STAMP)  ## Python virtual environment with nurimc and its dev tools

dashboard: $(STAMP)  ## the web console on a simulated bus: http://127.0.0.1:8485
	bash scripts/dashboard-assets.sh
	$(VENV)/bin/nurimc dashboard --sim

demo: $(STAMP)  ## the main job: a simulated bus, discovery, motion, live state
	$(VENV)/bin/nurimc demo

system-deps:  ## Debian packages the tests need (as root; skipped when present)
	bash scripts/system-deps.sh

generate:  ## regenerate every language's tables and the vectors from spec/
	python3 tools/generate.py
	python3 tools/make_vectors.py

check-generated:  ## fail if generated code or vectors are stale
	python3 tools/generate.py --check
	python3 tools/make_vectors.py --check

lint-python: $(STAMP)  ## ruff and mypy
	cd python && ../$(VENV)/bin/ruff check src tests && ../$(VENV)/bin/ruff format --check src tests && ../$(VENV)/bin/mypy

test-python: $(STAMP)  ## Python tests (protocol, simulator, library, CLI, dashboard)
	bash scripts/dashboard-assets.sh
	cd python && ../$(VENV)/bin/python -m pytest -q -p no:cacheprovider

fuzz-python-short: $(STAMP)  ## a short atheris run of the stream parser (part of make test)
	$(PY) python/fuzz/fuzz_parser.py -runs=200000 -max_len=256

fuzz-python:  $(STAMP) ## the long atheris run: 10 minutes
	$(PY) python/fuzz/fuzz_parser.py -max_total_time=600 -max_len=512

conformance: $(STAMP)  ## every language against the shared vectors
	python3 conformance/check.py python
	@if [ -f c/CMakeLists.txt ]; then python3 conformance/check.py c; fi
	@if [ -f ts/package.json ]; then python3 conformance/check.py ts; fi

test-c: system-deps  ## C library: build, tests under ASan/UBSan, short fuzz, Cortex-M build
	@if [ -f c/Makefile.inc ]; then $(MAKE) -f c/Makefile.inc test; else echo "no C library yet"; fi

test-ts: system-deps  ## TypeScript library and web console tests
	@if [ -f ts/package.json ]; then $(MAKE) -f ts/Makefile.inc test; else echo "no TypeScript library yet"; fi

test-e2e: $(STAMP) system-deps  ## web console end-to-end tests in headless Chromium
	@if [ -f e2e/Makefile.inc ]; then $(MAKE) -f e2e/Makefile.inc test; else echo "no web console tests yet"; fi

test: system-deps check-generated lint-python test-python fuzz-python-short conformance test-c test-ts test-e2e  ## everything CI runs

bench: $(STAMP)  ## run every benchmark and record the results (benchmarks/results/, ts/benchmarks/results/)
	$(PY) benchmarks/protocol_bench.py
	$(PY) benchmarks/library_bench.py
	$(PY) benchmarks/sim_realtime.py
	$(MAKE) -f c/Makefile.inc bench
	$(MAKE) -f ts/Makefile.inc ts-bench
	$(MAKE) -f e2e/Makefile.inc e2e-rate

.PHONY: help venv dashboard demo system-deps generate check-generated lint-python test-python fuzz-python-short fuzz-python conformance test-c test-ts test-e2e test bench
