# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv first.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

# Real DDS on this machine only, with a shared-memory segment big enough for camera frames.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export RMW_IMPLEMENTATION ?= rmw_fastrtps_cpp
export FASTRTPS_DEFAULT_PROFILES_FILE ?= $(CURDIR)/config/fastdds_large_shm.xml
export PYTHONHASHSEED := 0
# Python writes each module's bytecode on its first import (pip does not compile the 900 MB of
# packages ahead: about 40 s of CPU a virtualenv): nodes then start as on a robot, not compiling
# a hundred modules on every start (0.2-0.3 s of CPU each).
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-robot-stack bench soak lint bags docs clean venv regression params

venv: $(STAMP)

# tf2_msgs, hri_msgs and vision_msgs are not on PyPI: built from interfaces/ into the venv (about
# a minute and a half; on a robot they come from apt).
INTERFACES := requirements-interfaces.txt tools/build_interfaces.py $(wildcard interfaces/*/*.* interfaces/*/msg/*.msg)

$(STAMP): requirements.txt requirements-dev.txt setup.py $(INTERFACES)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade "pip>=24"
	$(PY) -m pip install --quiet --no-compile -r requirements-dev.txt -r requirements-interfaces.txt
	$(PY) tools/build_interfaces.py
	# The checkout, installed in place: every executable of setup.py lands in .venv/bin, as
	# `ros2 run` finds them after `colcon build`.
	$(PY) -m pip install --quiet --no-deps --no-build-isolation --editable .
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m human_tracker.demo --bag bags/head_basic --out out/demo

# Two workers, a test file each (the DDS tests wait on replays as much as they compute); then,
# alone, the tests that bound a time another busy process would break (marker `timed`).
IN_PARALLEL := -n 2 --dist loadfile -m 'not timed'

test: $(STAMP)
	$(PY) -m ruff check human_tracker test launch setup.py tools
	$(PY) -m pytest -q $(IN_PARALLEL) test
	$(PY) -m pytest -q -m timed test

# The tests again with a Jazzy robot's numpy 1.26 and OpenCV 4.6 (rosdep's versions) in .venv-robot;
# the colcon build is left to `make test`. numba keeps its compiled kernels apart for these versions.
# The interfaces are .venv's build, copied (same Python and ROS wheels; numpy 1.26 loads them).
ROBOT := .venv-robot
$(ROBOT)/.installed-stamp: requirements.txt requirements-robot.txt setup.py $(STAMP)
	test -x $(ROBOT)/bin/python || $(PYTHON) -m venv $(ROBOT)
	$(ROBOT)/bin/python -m pip install --quiet --upgrade "pip>=24"
	grep -v -E '^(numpy|opencv-python-headless)==' requirements.txt > $(ROBOT)/requirements.txt
	$(ROBOT)/bin/python -m pip install --quiet --no-compile -r $(ROBOT)/requirements.txt -r requirements-robot.txt
	$(ROBOT)/bin/python tools/build_interfaces.py --copy-from $(VENV)
	$(ROBOT)/bin/python -m pip install --quiet --no-deps --no-build-isolation --editable .
	touch $@

test-robot-stack: $(ROBOT)/.installed-stamp
	$(ROBOT)/bin/python -c "import cv2, numpy; print('robot stack: numpy', numpy.__version__, 'OpenCV', cv2.__version__)"
	NUMBA_CACHE_DIR=$(CURDIR)/$(ROBOT)/numba-cache $(ROBOT)/bin/python -m pytest -q $(IN_PARALLEL) test --ignore=test/test_package_build.py
	NUMBA_CACHE_DIR=$(CURDIR)/$(ROBOT)/numba-cache $(ROBOT)/bin/python -m pytest -q -m timed test --ignore=test/test_package_build.py

# config/human_tracker.yaml and docs/parameters.md's tables, made from the nodes' declarations.
params: $(STAMP)
	$(PY) -m human_tracker.ros.parameter_reference

lint: $(STAMP)
	$(PY) -m ruff check human_tracker test launch setup.py tools

# The README's annotated real sequence: sunshade (hand-held camera, 25 px head) tracked from its first box.
docs: $(STAMP)
	$(PY) -m human_tracker.cli track ../shared/data/real/sunshade --init 77,93,37,51 --quiet --out docs/sunshade

# Regenerate the bundled bags from the seeded scene generator.
bags: $(STAMP)
	$(PY) -m human_tracker.cli generate --all --out bags

clean:
	rm -rf $(VENV) .venv-contrib $(ROBOT) out build install log

# Speed lives here, never in timed tests: latency and throughput of the nodes over DDS.
CONTRIB := .venv-contrib/.installed-stamp
$(CONTRIB): requirements-contrib.txt
	test -x .venv-contrib/bin/python || $(PYTHON) -m venv .venv-contrib
	.venv-contrib/bin/python -m pip install --quiet -r requirements-contrib.txt
	touch $(CONTRIB)

bench: $(STAMP) $(CONTRIB)
	$(PY) -m human_tracker.bench --out out/bench --contrib-python .venv-contrib/bin/python --report docs/benchmark.md --readme README.md --evaluation docs/evaluation.md

# Every recorded run (bags and real sequences, seeds 0-4) gives the poses recorded in
# test/data/pose_hashes.json: a refactor's proof that it changed nothing (about 25 minutes).
regression: $(STAMP)
	$(PY) -m human_tracker.evaluation.regression check --jobs 2

# Issue-7 soak: 100,000 looped frames through the pipeline's nodes; memory and accounting.
soak: $(STAMP)
	$(PY) -m human_tracker.evaluation.soak --frames 100000 --out out/bench/soak.json
