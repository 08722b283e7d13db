# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
DEMO ?= scenarios/single_missile.yaml
OUT ?= out

ENDPOINT ?= tcp://127.0.0.1:5556
SERVE_ARGS ?= --realtime 1
TAIL_ARGS ?=

.PHONY: install lock golden demo test check typecheck bench lint clean tables serve tail tshark chromium \
  viewer-screenshot

# The application's install is locked: every dependency (the test extra's included) and the
# install's own tools at the exact versions and hashes of requirements/lock.txt, then shipradar
# itself (editable, --no-deps: nothing more is resolved or fetched). The lock is for CPython 3.11
# on x86-64 Linux (glibc >= 2.28), the machine the project, its CI and its published hashes run
# on; pyproject.toml keeps lower bounds for library users. A changed lock reinstalls.
LOCK := requirements/lock.txt

$(STAMP): pyproject.toml setup.py shipradar/_frames.c $(LOCK) requirements/dis.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --require-hashes --no-deps -r $(LOCK)
	$(PY) -m pip install -qq --no-deps --no-build-isolation -e .
	$(PY) -m pip uninstall -q -y opendis 2>/dev/null || true
	$(PY) -m pip check
	# opendis (--dis) after the check: its metadata's numpy<2 is not what it needs (requirements/dis.txt)
	$(PY) -m pip install -q --require-hashes --no-deps -r requirements/dis.txt
	touch $(STAMP)

install: $(STAMP)

# Refresh the lock: the newest releases that pyproject.toml's bounds (the test extra) and
# requirements/tools.in allow, for the lock's platform whatever machine runs it; review the diff
# (numpy, scipy and OpenBLAS move the stream's low bits: tests/golden/README.md)
lock: $(STAMP)
	$(VENV)/bin/uv pip compile pyproject.toml requirements/tools.in --extra test \
	  --generate-hashes --python-version 3.11 --python-platform x86_64-manylinux_2_28 \
	  --custom-compile-command 'make lock' --upgrade --quiet -o $(LOCK)

demo: $(STAMP)
	mkdir -p $(OUT)
	$(VENV)/bin/shipradar tables build $(DEMO)
	$(VENV)/bin/shipradar run $(DEMO) --record $(OUT)/demo.rec --overwrite
	@echo "watch it: $(VENV)/bin/shipradar view $(OUT)/demo.rec --open"

# Record the golden runs anew (tests/golden/README.md): after a deliberate change of the stream
# or of the lock; needs the locked install
golden: $(STAMP)
	$(PY) -m tests.golden

tables: $(STAMP)
	$(VENV)/bin/shipradar tables build $(DEMO)

serve: $(STAMP)
	$(VENV)/bin/shipradar run $(DEMO) --publish $(ENDPOINT) $(SERVE_ARGS)

tail: $(STAMP)
	$(VENV)/bin/shipradar tail $(ENDPOINT) $(TAIL_ARGS)

LINT_PATHS := shipradar sim sensors tables scenarios tests benchmarks examples

# the type check first, then the tests in two processes (pytest-xdist; this machine has 2
# cores): about 4 minutes
test: $(STAMP) typecheck tshark chromium
	MPLBACKEND=Agg $(PY) -m pytest -q -n 2 --dist loadgroup

# mypy with the pydantic plugin over the package shipradar (resolved from the checkout through
# the links in shipradar/); strict on the public API and sensors/ ([tool.mypy], pyproject.toml)
typecheck: $(STAMP)
	$(VENV)/bin/mypy

# the edit loop, under a minute: lint, type check and the tests not marked slow
check: $(STAMP)
	$(VENV)/bin/ruff check $(LINT_PATHS)
	$(VENV)/bin/mypy
	MPLBACKEND=Agg $(PY) -m pytest -q -n 2 --dist loadgroup -m "not slow"

# Wireshark's ASTERIX dissector checks our CAT048/CAT034 bytes (tests/test_asterix.py);
# installed when missing and we are root, never failing here (the tests say what is missing)
tshark:
	@command -v tshark >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	  tshark >/dev/null; } || echo "note: tshark not installed (apt-get install tshark)"

# Headless Chromium for the viewer's browser tests (tests/test_viewer_browser.py, driven by
# Playwright through executable_path): installed when missing and we are root, never failing
# here (the tests skip, or fail under CI, and say what is missing)
chromium:
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	  chromium >/dev/null; } || echo "note: chromium not installed (apt-get install chromium)"

# docs/viewer.png: the viewer on the demo recording (made by `make demo` when missing)
viewer-screenshot: $(STAMP) chromium
	test -f $(OUT)/demo.rec || $(MAKE) demo
	$(PY) -m shipradar.sim.adapters.viewer.screenshot $(OUT)/demo.rec docs/viewer.png --at 84.3 \
	  --zoom 2.5 --fade 10

bench: $(STAMP)
	for b in benchmarks/*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

lint: $(STAMP)
	$(VENV)/bin/ruff check $(LINT_PATHS)

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
