# Quick start: `make run` and `make test`. Both create .venv and install into it when needed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
INSTALL_INPUTS := pyproject.toml setup.py MANIFEST.in rtcore/_build.py firmware_profiles/__init__.py \
                  hand_service/firmware/_build.py board/Makefile \
                  $(wildcard csrc/*.c csrc/*.h board/core/* board/plant/* board/host/* board/inprocess/*)

.PHONY: run test test-soak test-thorough test-firsthour test-install test-faults test-boardcheck test-browser screenshot test-board-host test-board bench fuzz lint clean

# pip's byte-compiling runs on one core and takes the packages' own test suites too; compileall
# after it runs on every core and leaves those out (a module nobody imports needs no .pyc; one
# that is imported without one is compiled again by every process where PYTHONDONTWRITEBYTECODE
# is set, so the rest are compiled here)
$(STAMP): $(INSTALL_INPUTS)
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --no-compile --upgrade setuptools wheel cffi cantools  # the build requirements (no isolation)
	$(PY) -m pip install --quiet --no-compile --no-build-isolation --editable '.[test]'
	$(PY) -m compileall -q -j 0 -x '/tests?/' $(VENV)/lib
	@touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/hand-service run --demo

# The tests that keep time (service, api, transports, HIL, CLI, bench) run at normal priority;
# the CPU-bound ones (diagnose, effects, identification, replicate, export, commands, config, rtcore,
# wire, packaging, the recording reader, fuzz and its probes, the API's state table on a hand ticked
# by hand, the board's C build, the source scans) beside them
# at nice 19, in the time the first leave idle waiting on real time, so they cannot delay a deadline. The
# CPU-bound ones run in two pytest-xdist workers: one process alone left a core idle while
# the timed tests waited.
# `make test DURATIONS=--durations=25` lists the CPU-bound group's slowest.
CPU_TESTS := tests/diagnose tests/identification tests/replicate tests/export tests/commands tests/config \
             tests/rtcore tests/pinch tests/wire tests/packaging tests/test_recording.py tests/test_excel_csv.py \
             tests/test_import_graph.py tests/test_layout.py tests/test_cli_errors.py tests/board/test_board_build.py \
             tests/fuzz/test_config_fuzz.py tests/fuzz/test_csv_fuzz.py tests/fuzz/test_api_fuzz.py tests/effects \
             tests/service/test_no_false_fault.py tests/test_supervisor_surface.py tests/test_c_call_graph.py \
             tests/fuzz/test_probes.py tests/api/test_state_table.py
SELECT := -m "not slow and not thorough and not install and not fuzz and not faults and not boardcheck and not browser and not board and not qemu and not firsthour and not soak"

test: $(STAMP)
	$(VENV)/bin/ruff check .
	@nice -n 19 $(PY) -m pytest -q -p no:cacheprovider -n 2 $(SELECT) $(DURATIONS) $(CPU_TESTS) > .test-cpu.log 2>&1 & \
	cpu=$$!; \
	$(PY) -m pytest -q $(SELECT) $(addprefix --ignore=,$(CPU_TESTS)); timed=$$?; \
	wait $$cpu; cpu_status=$$?; \
	echo "-- the CPU-bound tests, run beside them at nice 19:"; cat .test-cpu.log; rm -f .test-cpu.log; \
	exit $$(( timed || cpu_status ))

# diagnose's and the simulator's repetitions beyond make test's slice (marker thorough): each
# library effect on the project's own generator named and recovered, the real-rig converter's
# fitter, a slow valve under a PI loop, the checks shown load-bearing, the costliest fine
# references, the optimised C driver, a small K's impedance to 0.2 Hz (make test keeps a test
# of each kind: two effects, the rigs' runs, the sanitized driver, a tenth of K_max)
test-thorough: $(STAMP)
	$(PY) -m pytest -q -p no:cacheprovider -n 2 -m thorough tests/diagnose tests/rtcore tests/pinch

# the README's first hour, every command as written, in a fresh directory (tests/test_first_hour.py)
test-firsthour: $(STAMP)
	$(PY) -m pytest -q -s -p no:cacheprovider -m firsthour tests/test_first_hour.py

# a wheel of the checkout, installed in a fresh venv outside it, runs (about 10 s)
test-install: $(STAMP)
	$(PY) -m pytest -q -m install

bench: $(STAMP)
	$(VENV)/bin/hand-service bench --json bench.json
	$(PY) -m pytest -q tests/bench --benchmark-enable --benchmark-only
	$(PY) -m pytest -q -m slow

# the fault matrix (docs/safety.md) on all three links, and a minute of fault-free sweeping on
# every demo profile (make test runs one kind of each family). Two sessions at a time: each is a host
# and a board in real time, mostly waiting, and a sweep must raise no false FAULT beside
# another's load as beside make test's; `-rA` prints what each measured
test-faults: $(STAMP)
	$(PY) -m pytest -q -rA -p no:cacheprovider -n 2 -m faults tests/hil/test_fault_matrix.py tests/hil/test_valve_board.py

# issue 40's soak: every link sweeping for HAND_SOAK_S (600 s) each with nothing injected, to
# run beside `make test` in another shell; no FAULT from a host stall under the watchdog.
# By hand, not in .ci/run (half an hour)
test-soak: $(STAMP)
	$(PY) -m pytest -q -s -p no:cacheprovider -m soak tests/hil/test_fault_matrix.py

# the HIL suite and the fault matrix against the reference firmware's host build (board/) over
# serial-v1 and SLCAN, the daemon over it, and host SIGKILL -> vent, 30 trials per link, with
# what it measured (about 3 min; make test runs a quick part of it)
test-board-host: $(STAMP)
	$(PY) -m pytest -q -s -p no:cacheprovider -m "board and not qemu" tests/board

# the firmware core cross-compiled: the Cortex-M image (board/cortexm) under qemu-system-arm
# -M mps2-an500 (handshake, closed loop, watchdog vent after the host's SIGKILL, board-check),
# the AVR image (board/avr) and the Arduino sketch (board/arduino) built and checked against
# the ATmega328P's flash and RAM, and cppcheck on board/ (about 1 min).
# Debian's packages are installed when missing.
BOARD_APT := gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm gcc-avr avr-libc binutils-avr \
             arduino-core-avr cppcheck
test-board: $(STAMP)
	@missing=$$(for p in $(BOARD_APT); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then SUDO=$$(test "$$(id -u)" = 0 || echo sudo); \
	  $$SUDO apt-get install -y $$missing || { $$SUDO apt-get update && $$SUDO apt-get install -y $$missing; }; fi
	$(MAKE) -C board BUILD=build PYTHON=../$(PY) cortexm avr arduino cppcheck
	$(PY) -m pytest -q -s -p no:cacheprovider -m qemu tests/board

# board-check against the C board over SLCAN, and every image that breaks a rule on purpose
# on all three links with every check run (two at a time: each mostly waits on the board; make test runs the board on serial
# and virtual CAN and each broken image once)
test-boardcheck: $(STAMP)
	$(PY) -m pytest -q -p no:cacheprovider -n 2 -m boardcheck tests/boardcheck

# the live view (docs/view.md) in headless Chromium against a real daemon: the page, its plots,
# its E-stop, a wrong token (`make screenshot` also refreshes docs/img/view.png), and what the view costs the tick (about 3 min;
# make test runs the view's server without a browser). Debian's chromium is installed if missing.
test-browser: $(STAMP)
	@test -x /usr/bin/chromium || { SUDO=$$(test "$$(id -u)" = 0 || echo sudo); \
	  $$SUDO apt-get install -y chromium || { $$SUDO apt-get update && $$SUDO apt-get install -y chromium; }; }
	@$(PY) -c "import playwright" 2>/dev/null || $(PY) -m pip install --quiet 'playwright>=1.40'
	$(PY) -m pytest -q -s -p no:cacheprovider -m "browser and not slow" tests/browser

screenshot:
	SCREENSHOT_TO=$(CURDIR)/docs/img/view.png $(MAKE) test-browser

# every file reader and the control API fed 5 000 fuzzed inputs each (make test runs 200 each), and
# the C step against the Python reference on 400 new hands (make test: 25 fixed ones)
fuzz: $(STAMP)
	$(PY) -m pytest -q -p no:cacheprovider -m fuzz tests/fuzz tests/rtcore/test_equivalence.py

lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) build *.egg-info rtcore/_rtcore.c rtcore/*.so csrc/*.o
