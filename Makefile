# Two commands: `make demo` and `make test`.  Both create .venv when it is missing.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# pytest-xdist workers of `make test` (the suite is sized for two cores)
WORKERS ?= 2

.PHONY: demo test install clean bench

$(BIN)/python:
	$(PY) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test,dask,fast,fmi]"
	$(BIN)/python -m compileall -q mjbench controllers  # the editable sources' bytecode, as pip does for wheels
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/mjbench reproduce all --out results --force --jobs 2

# the suite on two workers (pytest-xdist; a file's tests stay on one worker: its module fixtures are built once),
# the slowest tests listed at the end
test: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python -m pytest -q -n $(WORKERS) --dist loadfile --durations=15

# the bench also measures against Exudyn (optional extra `bench`, part scripts/bench_parts/exudyn.py)
$(VENV)/.installed-bench: $(STAMP)
	$(BIN)/pip install --quiet -e ".[test,dask,fast,bench]"
	touch $@

bench: $(VENV)/.installed-bench
	$(BIN)/python scripts/bench.py

clean:
	rm -rf $(VENV) results
