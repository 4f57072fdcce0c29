# hex_control: set-up, main job, tests, benchmarks.
# Every target sets up first; a second run with nothing changed only checks the stamps.
PYTHON ?= python3
VENV   ?= .venv
BUILD  ?= build
PY     := $(VENV)/bin/python
MSG_SOURCES := $(shell find msg_defs -path msg_defs/tf2_msgs -prune -o -type f \( -name '*.msg' -o -name '*.srv' \
                 -o -name '*.action' \) -print) msg_defs/CMakeLists.txt msg_defs/package.xml \
               msg_defs/cmake/hex_interfaces.cmake
TF2_SOURCES := $(wildcard msg_defs/tf2_msgs/msg/*.msg) msg_defs/tf2_msgs/CMakeLists.txt msg_defs/tf2_msgs/package.xml \
               msg_defs/cmake/hex_interfaces.cmake

.PHONY: setup demo test lint bench lock clean

# the byte code (the venv's, then the tests') and the two interface builds need only the venv and
# not each other: run side by side (a fresh set-up on two cores: 45 s, where one after the other
# took 54 s)
SETUP_STAMPS := $(VENV)/.stamp-package $(VENV)/.stamp-test-bytecode
setup:
	@$(MAKE) --no-print-directory -q $(SETUP_STAMPS) || $(MAKE) --no-print-directory -j3 $(SETUP_STAMPS)

# 1. virtualenv with the pinned closure (ROS 2 Kilted wheels included): by uv, in a few seconds
#    where pip takes 70 s on a cold cache (the CI's set-up); by pip if uv cannot. The venv is
#    made without pip and uv puts in the pinned one (0.4 s, where the venv's ensurepip took 3.7)
UV_VERSION := 0.13.9
PIP_VERSION := 23.2.1
UV := $(BUILD)/uv-$(UV_VERSION)/bin/uv
$(VENV)/.stamp-deps: requirements.lock
	test -x $(PY) || $(PYTHON) -m venv --without-pip $(VENV)
	((test -x $(UV) || (rm -rf $(BUILD)/uv-$(UV_VERSION) && $(PYTHON) -m pip install --quiet \
	    --disable-pip-version-check --root-user-action=ignore --target $(BUILD)/uv-$(UV_VERSION) uv==$(UV_VERSION))) && \
	  $(UV) pip install --quiet --python $(PY) -r requirements.lock pip==$(PIP_VERSION)) || \
	  (echo "set-up: no uv here; the closure goes in by pip (slower)" && \
	   ($(PY) -m pip --version > /dev/null 2>&1 || $(PY) -m ensurepip --default-pip > /dev/null) && \
	   $(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock pip==$(PIP_VERSION))
	touch $@

# 1b. its byte code, written once (where PYTHONDONTWRITEBYTECODE is set, every process compiles
#     what it imports, and a suite starts some 300), the packages' own tests left out (a quarter
#     of the files, imported by nothing here): 10 s and 19 CPU s, against 18 s and 27 CPU s for all;
#     and Ray's libraries that a campaign's tasks never import (2.4 CPU s). Niced, as it only
#     fills in beside the build of hex_control_msgs, the set-up's longest path
NEVER_IMPORTED := '/tests?/|/ray/(rllib|data|serve|tune|train|llm|air)/'
$(VENV)/.stamp-bytecode: $(VENV)/.stamp-deps
	nice -n 10 $(PY) -m compileall -q -j0 -x $(NEVER_IMPORTED) \
	  $$($(PY) -c "import sysconfig; print(sysconfig.get_paths()['purelib'])") > /dev/null
	touch $@

# 1c. the tests' byte code, their asserts rewritten as pytest does (scripts/test_bytecode.py):
#     with PYTHONDONTWRITEBYTECODE set pytest writes none, and each of the four workers rewrote
#     every test module (their start 13-14 s and 25 CPU s, with this 6 s and 10 CPU s)
$(VENV)/.stamp-test-bytecode: $(VENV)/.stamp-deps $(wildcard test/*.py) scripts/test_bytecode.py
	nice -n 10 $(PY) scripts/test_bytecode.py test
	touch $@

# 2. interface packages, built into the venv prefix with their C and Python interfaces only
#    (HEX_PYTHON_ONLY: 30 s where all generators take 75). tf2_msgs (TFMessage, the type of /tf;
#    not among the ROS wheels, so built from its standard definition) with CMake.
$(VENV)/.stamp-tf2-msgs: $(VENV)/.stamp-deps $(TF2_SOURCES)
	mkdir -p $(BUILD)
	cmake -S msg_defs/tf2_msgs -B $(BUILD)/tf2_msgs -DCMAKE_PREFIX_PATH=$(CURDIR)/$(VENV) \
	  -DCMAKE_INSTALL_PREFIX=$(CURDIR)/$(VENV) -DPython3_EXECUTABLE=$(CURDIR)/$(PY) \
	  -DBUILD_TESTING=OFF -DHEX_PYTHON_ONLY=ON > $(BUILD)/tf2_msgs.log 2>&1 || (cat $(BUILD)/tf2_msgs.log; exit 1)
	cmake --build $(BUILD)/tf2_msgs -j2 >> $(BUILD)/tf2_msgs.log 2>&1 || (tail -50 $(BUILD)/tf2_msgs.log; exit 1)
	cmake --install $(BUILD)/tf2_msgs >> $(BUILD)/tf2_msgs.log 2>&1 || (tail -50 $(BUILD)/tf2_msgs.log; exit 1)
	$(PY) -c "import tf2_msgs.msg"
	touch $@

#    hex_control_msgs by colcon, in the workspace test_colcon_build.py builds, with its command
#    (scripts/colcon_workspace.py), then installed from that build into the venv: the test's
#    build of it is then up to date (on a fresh clone it had built it again: 42 CPU s). That
#    workspace is build/colcon_ws whatever BUILD says (the test's fixed place)
$(VENV)/.stamp-msgs: $(VENV)/.stamp-deps $(MSG_SOURCES) scripts/colcon_workspace.py
	mkdir -p $(BUILD)
	$(PY) scripts/colcon_workspace.py interfaces $(VENV) > $(BUILD)/hex_control_msgs.log 2>&1 \
	  || (tail -50 $(BUILD)/hex_control_msgs.log; exit 1)
	$(PY) -c "import hex_control_msgs.msg, hex_control_msgs.srv, hex_control_msgs.action"
	touch $@

# 3. hex_control itself, editable, its C kernels built in place, its byte code written
#    (as the venv's, 1b). setup.cfg puts the scripts in lib/hex_control (the layout `ros2 run`
#    expects); link the user-facing ones onto the venv's PATH too.
$(VENV)/.stamp-package: $(VENV)/.stamp-bytecode $(VENV)/.stamp-tf2-msgs $(VENV)/.stamp-msgs setup.py setup.cfg \
                       hex_control/grinding/_contact_c.c hex_control/kinematics/_stewart_c.c
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	$(PY) -m compileall -q hex_control
	cd $(VENV)/bin && for script in ../lib/hex_control/hexctl ../lib/hex_control/hex-*; do \
	  ln -sf $$script .; done
	touch $@

demo: setup
	$(VENV)/bin/hexctl demo

# one OpenBLAS thread (unless set): beside a busy graph or a loaded machine its worker threads
# spin for cores others hold (a shaping test took 507 s under two CPU burners, 23 s with one).
# Four workers on two cores: a worker waits for part of its time (discovery, a lock-step chain
# holding one core): 265-283 s where three took 310-328, alternating runs; with four the cores
# are 90 % busy, with six 98 % and the run slower (docs/testing.md)
test: setup
	OPENBLAS_NUM_THREADS=$${OPENBLAS_NUM_THREADS:-1} $(PY) -m pytest -q -n 4 --dist worksteal --durations=20 test

lint: setup
	$(VENV)/bin/ruff check hex_control test scripts

bench: setup
	$(VENV)/bin/hexctl bench

lock:
	$(PYTHON) -m venv $(BUILD)/lock-venv
	$(BUILD)/lock-venv/bin/python -m pip install --quiet -r requirements.in
	$(PYTHON) scripts/freeze_lock.py $(BUILD)/lock-venv/bin/python > requirements.lock

clean:
	rm -rf $(VENV) $(BUILD) build/colcon_ws
