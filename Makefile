# Two commands for a fresh machine with Python 3.11: `make run` and `make test`.
# Each (re)creates .venv idempotently, then does its job. `make lock` refreshes requirements.lock.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
LOCK   := requirements.lock

# ROS 2 from wheels: the venv is the ament prefix; isolate DDS traffic to this host.
export AMENT_PREFIX_PATH := $(abspath $(VENV))
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export PYTHONDONTWRITEBYTECODE := 1

# Suites at the numerical extremes: run again under these OpenBLAS kernels (their answers must
# hold under any BLAS kernel / SIMD path, not only the one this machine picks).
EXTREME_TESTS := test/core/test_stability.py test/core/test_stability_inputs.py \
  test/core/test_stability_newton.py test/core/motion/test_vectorised_extremes.py \
  test/core/motion/test_extremes_to_the_last_digit.py
OPENBLAS_KERNELS := Haswell Sandybridge

.PHONY: venv run test check fuzz bench lock clean

venv: $(STAMP)

# exact versions from the lock: a fresh machine gets what CI tested
$(STAMP): requirements.txt $(LOCK) setup.py setup.cfg package.xml pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip -c $(LOCK)
	$(PY) -m pip install --quiet -r requirements.txt -c $(LOCK)
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/linkage_node --ros-args -p demo_sweep:=true

# lint, format, types and the core's import contract (configured in pyproject.toml)
check: $(STAMP)
	$(VENV)/bin/ruff check linkage_ros test bench
	$(VENV)/bin/ruff format --check linkage_ros test bench
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

test: check
	$(PY) -m pytest -q test
	for k in $(OPENBLAS_KERNELS); do \
	  echo "== $(EXTREME_TESTS) under OPENBLAS_CORETYPE=$$k"; \
	  OPENBLAS_CORETYPE=$$k $(PY) -m pytest -q -p no:cacheprovider $(EXTREME_TESTS) || exit 1; \
	done

# the long fuzz run of the scene loader and the request checks (make test runs a short one)
fuzz: $(STAMP)
	LINKAGE_FUZZ=long $(PY) -m pytest -q -p no:cacheprovider test/test_fuzz.py

bench: $(STAMP)
	$(VENV)/bin/linkage bench --write docs/BENCHMARKS.md

# Re-resolve requirements.txt in a scratch venv and pin every installed version.
lock:
	rm -rf .lock-venv
	$(PYTHON) -m venv .lock-venv
	.lock-venv/bin/pip install --quiet --upgrade pip
	.lock-venv/bin/pip install --quiet -r requirements.txt
	{ echo '# Exact versions `make` installs (pip constraints). Refresh: make lock'; \
	  .lock-venv/bin/pip freeze --all --exclude-editable; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)
	rm -rf .lock-venv

clean:
	rm -rf $(VENV) .lock-venv build *.egg-info
