# bike_rig: make demo | make test | make test-fast | make lint | make docs | make bench | make soak | make fuzz | make clean
#
# The tests also need Debian's chromium (/usr/bin/chromium, the report's render test) and tmux
# (/usr/bin/tmux, the operator console's tests): tools/setup_debian.sh installs them with
# apt-get before pytest runs, and does nothing when they are there.
#
# Every target that runs code first brings the project-local .venv up to date with
# tools/setup_venv.sh (ROS 2 Kilted wheels, bike_rig_msgs built with cmake into the venv,
# bike_rig installed with `pip install .`). That step is idempotent and keyed on the hashes
# of its inputs: with nothing changed it takes about a second.

SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.DEFAULT_GOAL := test

VENV := $(CURDIR)/.venv
BIN := $(VENV)/bin
BENCH_DEPS := $(CURDIR)/.bench-deps
# folders that exist (ruff fails on a missing path)
LINT_PATHS := $(wildcard bike_rig test bench tools docs)
# the benchmarks (bench/bench_*.py; the other files there are their helpers)
BENCH_SCRIPTS := $(sort $(wildcard bench/bench_*.py))

# Every ROS process started from here (tests, demo, benches) discovers on loopback only and
# finds the packages in the venv, which is the ROS prefix. ROS_DOMAIN_ID is chosen per run
# by bike_rig.ros.env (tests: the ros_env fixture).
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export AMENT_PREFIX_PATH := $(VENV)
export CMAKE_PREFIX_PATH := $(VENV)
export RMW_IMPLEMENTATION := rmw_fastrtps_cpp
export MPLBACKEND := Agg
unexport ROS_LOCALHOST_ONLY ROS_STATIC_PEERS

# hard limits so that nothing can hang CI (each test also has its own: pyproject.toml's timeout)
PYTEST_TIMEOUT_S := 1800
BENCH_TIMEOUT_S := 1800

# The suite runs in PYTEST_WORKERS processes (pytest-xdist), each test file on one worker (its
# module fixtures built once). Most of the ROS tests' time is waiting for other processes, so
# more workers than cores pays; each worker reserves a ROS domain of its own.
PYTEST_WORKERS ?= 4
PYTEST_ARGS ?=
PYTEST := $(BIN)/python -m pytest --dist loadfile $(PYTEST_ARGS)
# the fast tier: no ROS process, no statistical campaign; its tests compute, one worker a core
FAST_WORKERS ?= 2
FAST_MARKERS := not ros and not slow

.PHONY: venv bench-deps debian-tools demo test test-fast lint typecheck docs pytest bench soak fuzz clean

venv:
	@tools/setup_venv.sh

bench-deps:
	@tools/setup_venv.sh --bench

debian-tools:
	@tools/setup_debian.sh
	@tools/setup_node.sh

demo: venv
	$(BIN)/bike-rig demo

lint: venv
	$(BIN)/ruff check $(LINT_PATHS)
	$(BIN)/ruff format --check $(LINT_PATHS)

typecheck: venv
	$(BIN)/mypy bike_rig

# the manual (docs/, Sphinx + MyST) into build/docs/; any warning fails the build
docs: venv
	$(BIN)/sphinx-build -W --keep-going -q -b html docs build/docs

pytest: venv
	@tools/setup_debian.sh
	@tools/setup_node.sh
	timeout -k 30 $(PYTEST_TIMEOUT_S) $(PYTEST) -n $(PYTEST_WORKERS)

# pytest's fast tier alone (e.g. make test-fast PYTEST_ARGS="test/core -x")
test-fast: venv
	@tools/setup_debian.sh
	timeout -k 30 $(PYTEST_TIMEOUT_S) $(PYTEST) -n $(FAST_WORKERS) -m "$(FAST_MARKERS)"

# in this order: ruff (lint and format), mypy, the manual, pytest (each stops the run on failure)
test: venv
	$(BIN)/ruff check $(LINT_PATHS)
	$(BIN)/ruff format --check $(LINT_PATHS)
	$(BIN)/mypy bike_rig
	$(BIN)/sphinx-build -W --keep-going -q -b html docs build/docs
	@tools/setup_debian.sh
	@tools/setup_node.sh
	timeout -k 30 $(PYTEST_TIMEOUT_S) $(PYTEST) -n $(PYTEST_WORKERS)

# bicycleparameters lives only in .bench-deps/ (put on PYTHONPATH here), never in the test env
bench: bench-deps
	@test -n "$(BENCH_SCRIPTS)" || { echo "no bench/*.py scripts"; exit 0; }
	@for script in $(BENCH_SCRIPTS); do \
	  echo "== $$script"; \
	  PYTHONPATH=$(BENCH_DEPS) timeout -k 30 $(BENCH_TIMEOUT_S) $(BIN)/python $$script || exit $$?; \
	done

# the long fuzz campaign of every file reader: 10,000 damaged inputs each (tools/fuzz.py; e.g.
# make fuzz FUZZ_ARGS="--seed 20261125 --reader rig"); exits 1 on any crash or hang
FUZZ_ARGS ?=
fuzz: venv
	timeout -k 30 10800 $(BIN)/python tools/fuzz.py --inputs 10000 $(FUZZ_ARGS)

# a long live session (default: 1 h at the rig's 1 kHz): every process's memory over time
# (tools/soak.py; e.g. make soak SOAK_ARGS="--seconds 600 --time-scale 10"; a short one:
# SOAK_ARGS="--seconds 45 --time-scale 100 --every 2 --min-results 40"); exits 1 on growth
SOAK_ARGS ?=
soak: venv
	timeout -k 30 10800 $(BIN)/python tools/soak.py $(SOAK_ARGS)

clean:
	rm -rf $(VENV) $(BENCH_DEPS) build install log *.egg-info \
	  .mypy_cache .ruff_cache .pytest_cache .hypothesis
	find bike_rig test bench -name __pycache__ -type d -prune -exec rm -rf {} + 2>/dev/null || true
