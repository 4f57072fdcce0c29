# hex_control: set-up, main job, tests, benchmarks.
# Every target sets up first; a second run with nothing changed only checks the stamps.
PYTHON ?= python3
VENV   ?= .venv
BUILD  ?= build
PY     := $(VENV)/bin/python
MSG_SOURCES := $(shell find msg_defs -type f -name '*.msg' -o -type f -name '*.srv' -o -type f -name '*.action') \
               msg_defs/CMakeLists.txt msg_defs/package.xml

.PHONY: setup demo test lint bench lock clean

setup: $(VENV)/.stamp-package

# 1. virtualenv with the pinned closure (ROS 2 Kilted wheels included)
$(VENV)/.stamp-deps: requirements.lock
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.lock
	touch $@

# 2. interface package hex_control_msgs, built with CMake into the venv prefix
$(VENV)/.stamp-msgs: $(VENV)/.stamp-deps $(MSG_SOURCES)
	mkdir -p $(BUILD)
	cmake -S msg_defs -B $(BUILD)/msg_defs -DCMAKE_PREFIX_PATH=$(CURDIR)/$(VENV) \
	  -DCMAKE_INSTALL_PREFIX=$(CURDIR)/$(VENV) -DPython3_EXECUTABLE=$(CURDIR)/$(PY) \
	  -DBUILD_TESTING=OFF > $(BUILD)/msg_defs.log 2>&1 || (cat $(BUILD)/msg_defs.log; exit 1)
	cmake --build $(BUILD)/msg_defs -j2 >> $(BUILD)/msg_defs.log 2>&1 || (tail -50 $(BUILD)/msg_defs.log; exit 1)
	cmake --install $(BUILD)/msg_defs >> $(BUILD)/msg_defs.log 2>&1 || (tail -50 $(BUILD)/msg_defs.log; exit 1)
	$(PY) -c "import hex_control_msgs.msg, hex_control_msgs.srv, hex_control_msgs.action"
	touch $@

# 3. hex_control itself, editable. setup.cfg puts the scripts in lib/hex_control (the
#    layout `ros2 run` expects); link the user-facing ones onto the venv's PATH too.
$(VENV)/.stamp-package: $(VENV)/.stamp-msgs setup.py setup.cfg
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	cd $(VENV)/bin && for script in ../lib/hex_control/hexctl ../lib/hex_control/hex-*; do \
	  ln -sf $$script .; done
	touch $@

demo: setup
	$(VENV)/bin/hexctl demo

# one OpenBLAS thread (unless set): beside a busy graph or a loaded machine its worker threads
# spin for cores others hold (a shaping test took 507 s under two CPU burners, 23 s with one)
test: setup
	OPENBLAS_NUM_THREADS=$${OPENBLAS_NUM_THREADS:-1} $(PY) -m pytest -q -n 2 --dist worksteal --durations=20 test

lint: setup
	$(VENV)/bin/ruff check hex_control test scripts

bench: setup
	$(VENV)/bin/hexctl bench

lock:
	$(PYTHON) -m venv $(BUILD)/lock-venv
	$(BUILD)/lock-venv/bin/python -m pip install --quiet -r requirements.in
	$(PYTHON) scripts/freeze_lock.py $(BUILD)/lock-venv/bin/python > requirements.lock

clean:
	rm -rf $(VENV) $(BUILD)
