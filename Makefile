# Two commands do all the set-up on a fresh machine (Debian 12, Python 3.11, no ROS):
#   make demo   - create .venv, install ROS 2 Jazzy wheels + this package, run the main job
#   make test   - same set-up, then the whole test suite
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
OUT ?= out

.PHONY: demo test test-slow bench install clean

install: $(STAMP)

$(STAMP): requirements.txt setup.py setup.cfg package.xml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet -r requirements.txt
	$(VENV)/bin/pip install --quiet --no-deps -e .
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/tca_sim demo --out $(OUT)

PYTEST := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -q --timeout=600 -n 2 \
	--dist loadfile --durations=25

test: $(STAMP)
	$(PYTEST) -m "not slow" test

test-slow: $(STAMP)
	$(PYTEST) -m slow test

bench: $(STAMP)
	$(VENV)/bin/tca_sim bench
	for b in bench/bench_*.py; do $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) $(OUT) build install log .pytest_cache
