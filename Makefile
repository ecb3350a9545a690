# MillBlocks: `make test` and (from the web issue on) `make run` set everything up themselves.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test lint typecheck pytest system-deps wheel wheel-native regen-golden clean bench bench-serial load
HOST ?= 127.0.0.1
PORT ?= 5000
WORKERS ?= 2

# The virtual environment is rebuilt whenever the dependency pins change. The Debian
# packages running needs (python3-venv) are installed first, when missing.
$(STAMP): pyproject.toml constraints.txt setup.py
	bash scripts/install-system-deps run
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[dev]'
	touch $(STAMP)

# Debian packages the tests need (listed in debian-packages.txt); installed only when missing.
system-deps:
	bash scripts/install-system-deps test

# The wheel a shop installs (pure Python), and the same with the G-code importer compiled by
# mypyc (setup.py; ~2 min of gcc; needs gcc and python3-dev). Both into dist/.
wheel: $(STAMP)
	$(PY) -m pip wheel --quiet --no-deps -w dist .

wheel-native: $(STAMP)
	MILLBLOCKS_MYPYC=1 $(PY) -m pip wheel --quiet --no-build-isolation --no-deps -w dist .

# The web editor on http://127.0.0.1:5000 with the library in instance/ (SQLite; set
# DATABASE_URL for PostgreSQL). The database is migrated (and given its demo programs the
# first time) before the workers start.
run: $(STAMP)
	$(VENV)/bin/millblocks db upgrade
	$(VENV)/bin/millblocks serve --host $(HOST) --port $(PORT) --workers $(WORKERS)

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

typecheck: $(STAMP)
	$(VENV)/bin/mypy

# The suite runs inside a throwaway PostgreSQL cluster (Debian's pg_virtualenv sets PG*),
# so the storage tests run on SQLite and on a real PostgreSQL. -t puts the cluster in a
# temporary directory even as root, so two runs side by side do not collide.
# pytest exits 5 when it collected nothing: treat that as a failure, not a pass.
pytest: $(STAMP) system-deps
	pg_virtualenv -t $(PY) -m pytest $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests: failing" >&2; exit 1; fi; exit $$rc

test: lint typecheck pytest

DURATION ?= 60

# Benchmarks (issue 10): figures and same-run ratios into docs/benchmarks.md (~6-10 min,
# bounded at 15). Not part of `make test`.
bench: $(STAMP) system-deps
	$(PY) -m pip install --quiet --no-deps -r bench/requirements.txt
	$(PY) -m bench.run

# RS-232 send of a 50 KB program against the 4800-baud line rate over a socat pty pair
# (issue 8; ~2 min); figures in docs/rs232.md.
bench-serial: $(STAMP) system-deps
	$(PY) -m bench.serial_send
	$(PY) -m bench.serial_service

# Load test (issue 9): 20 + 5 editors for $(DURATION) s against gunicorn, on SQLite and on a
# throwaway PostgreSQL cluster; figures into docs/load.md.
load: $(STAMP) system-deps
	$(PY) -m bench.load --duration $(DURATION)
	pg_virtualenv -t $(PY) -m bench.load --database postgresql --duration $(DURATION)

# Rewrite the expected files of the golden tests from the current code (review the diff!).
regen-golden: $(STAMP)
	MILLBLOCKS_REGEN_GOLDEN=1 $(PY) -m pytest tests/test_golden.py tests/test_verify.py -q -k "golden"

clean:
	rm -rf $(VENV) build dist .mypy_cache .pytest_cache .ruff_cache .hypothesis
	find app -name '*.so' -delete  # left by builds of older versions, which compiled in place
