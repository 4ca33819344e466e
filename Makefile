# The two commands a newcomer needs: `make demo` (the main job) and `make test` (every check).
# Both create .venv and install whatever is missing, Graphviz's `dot` included.

# The interpreter .venv is made with (`make PYTHON=...` chooses another): the first of
# PYTHON_CANDIDATES that is Python 3.11 or newer and can make a virtual environment with
# pip. The distribution's /usr/bin/python3 comes first: Debian's is a statically linked
# interpreter, which runs the library about 18 % faster than one linked against a shared
# libpython, as pyenv builds by default (docs/installation.md, docs/performance.md).
PYTHON_CANDIDATES ?= /usr/bin/python3 python3
PYTHON ?= $(firstword $(foreach p,$(PYTHON_CANDIDATES),$(shell $(p) -c \
	'import sys, ensurepip, venv; sys.exit(sys.version_info < (3, 11))' >/dev/null 2>&1 \
	&& echo $(p))) python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
DEMO_OUT ?= demo-output

.PHONY: demo test lint typecheck unit docs bench bench-doc graphviz venv clean firmware avr-toolchain \
	flash fuses avrdude zmq-dev mutation mutation-python mutation-firmware

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || { echo "making $(VENV) with $(PYTHON)"; $(PYTHON) -m venv $(VENV); }
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[dev]'
	@touch $(STAMP)

# Debian's graphviz provides `dot`; install it when missing and we may (root + apt-get).
graphviz:
	@if command -v dot >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's graphviz (dot is missing)"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq graphviz >/dev/null; \
	else \
		echo "warning: Graphviz 'dot' is missing; install it (Debian: sudo apt-get install graphviz) to render .svg/.png (.dot files are still written)"; \
	fi

# Debian's gcc-avr and avr-libc build the bridge firmware, the host's gcc its
# unit-test build, libsimavr-dev (with pkg-config) runs it in simavr; install what is
# missing when we may (root + apt-get), as for Graphviz. libelf-dev: simavr.pc requires
# libelf, so without it pkg-config says simavr is missing and the simavr tests skip.
AVR_PACKAGES := gcc-avr binutils-avr avr-libc gcc libsimavr-dev libelf-dev pkg-config
avr-toolchain:
	@if command -v avr-gcc >/dev/null 2>&1 && [ -f /usr/lib/avr/include/avr/io.h ] \
		&& command -v cc >/dev/null 2>&1 && pkg-config --exists simavr 2>/dev/null; then :; \
	elif [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's $(AVR_PACKAGES) (some are missing)"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(AVR_PACKAGES) >/dev/null; \
	else \
		echo "warning: the AVR toolchain or simavr is missing; install them (Debian: sudo apt-get install $(AVR_PACKAGES)) to build and simulate firmware/piratebay"; \
	fi

# Debian's libzmq3-dev and cppzmq-dev build the Groot2 oracle's client (BT.CPP's own
# protocol header on cppzmq: tests/groot2_oracle, built once and cached by the tests);
# install them when missing and we may (root + apt-get), as for Graphviz.
ZMQ_PACKAGES := libzmq3-dev cppzmq-dev
zmq-dev:
	@if [ -f /usr/include/zmq.h ] && [ -f /usr/include/zmq.hpp ]; then :; \
	elif [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's $(ZMQ_PACKAGES) (some are missing)"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(ZMQ_PACKAGES) >/dev/null; \
	else \
		echo "warning: libzmq3-dev or cppzmq-dev is missing; install them (Debian: sudo apt-get install $(ZMQ_PACKAGES)) for the Groot2 oracle tests (they skip without)"; \
	fi

# The PIRATEbay bridge firmware: layout header from the robot description, ELF, HEX,
# flash and SRAM use (firmware/piratebay/build/); the reference PICO board firmware
# (firmware/pico/build/); and the simavr harness that runs them (firmware/simavr/build/),
# where libsimavr is installed.
FIRMWARE_ROBOT = ROBOT=$(abspath $(or $(ROBOT),hardware/pirate.yaml)) \
	PIRATE_BT=$(abspath $(BIN)/pirate-bt)
firmware: $(STAMP) avr-toolchain
	$(MAKE) -C firmware/piratebay $(FIRMWARE_ROBOT)
	$(MAKE) -C firmware/pico $(FIRMWARE_ROBOT)
	@if pkg-config --exists simavr 2>/dev/null; then $(MAKE) -C firmware/simavr; \
	else echo "note: libsimavr-dev missing: the simavr harness is not built"; fi

# Flash the bridge through the Mega's bootloader: `make flash PORT=/dev/ttyACM0`.
# `make fuses` sets its fuses (brown-out 4.3 V) with an ISP programmer
# (PROGRAMMER=usbasp ISP_PORT=usb by default). docs/firmware.md, Flash. avrdude is
# installed when missing and we may, as the toolchain is.
FLASH_PACKAGES := avrdude
avrdude:
	@if command -v avrdude >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's $(FLASH_PACKAGES)"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(FLASH_PACKAGES) >/dev/null; \
	else echo "warning: avrdude is missing (Debian: sudo apt-get install avrdude)"; fi
flash: firmware avrdude
	$(MAKE) -C firmware/piratebay $(FIRMWARE_ROBOT) flash PORT=$(PORT)
fuses: avrdude
	$(MAKE) -C firmware/piratebay fuses $(if $(PROGRAMMER),PROGRAMMER=$(PROGRAMMER)) \
		$(if $(ISP_PORT),ISP_PORT=$(ISP_PORT))

lint: $(STAMP)
	$(BIN)/ruff check pirate_bt tests benchmarks examples
	$(BIN)/ruff format --check pirate_bt tests benchmarks examples
	$(BIN)/lint-imports --no-cache

typecheck: $(STAMP)
	$(BIN)/mypy --strict pirate_bt

# Bytecode written even where the environment says not to (PYTHONDONTWRITEBYTECODE):
# the test processes and the hundreds of pirate-bt processes the tests start then load
# pirate_bt and pytest's rewritten test modules compiled, not from source each time.
unit: $(STAMP) graphviz avr-toolchain zmq-dev
	PYTHONDONTWRITEBYTECODE= $(BIN)/pytest

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir site

test: lint typecheck unit docs

demo: $(STAMP) graphviz
	$(BIN)/pirate-bt demo --output $(DEMO_OUT)

# Mutation testing (docs/testing.md), not part of `make test`: mutmut on the protective
# layer and the wire (mutants/ keeps every result, so a run resumes; rm -rf mutants for a
# fresh one), then the bridge firmware's fixed catalogue of operator mutations. At most
# MUTATION_CHILDREN test processes at a time (the project's machine has 2 cores).
MUTATION_CHILDREN ?= 2
mutation: mutation-python mutation-firmware

mutation-python: $(STAMP)
	$(BIN)/python tests/mutation/run.py --children $(MUTATION_CHILDREN)

mutation-firmware: $(STAMP) avr-toolchain
	$(BIN)/python tests/mutation/firmware.py --jobs $(MUTATION_CHILDREN)

# Every benchmark in turn (benchmarks/run_all.py), then the tables they own in
# docs/performance.md rewritten from what they published, only if all succeeded
# (docs/testing.md, Benchmarks). BENCH_ARGS: `--full` (each script's own defaults:
# the as-built, navigator and survey figures in full), names (`trace mission`: only
# those), `--set interop="5 --no-sizes"`, `--results DIR` (keep the results).
# `make bench-doc BENCH_RESULTS=DIR` writes kept results into the document again.
BENCH_ARGS ?=
BENCH_DOC ?= docs/performance.md
bench: $(STAMP) graphviz avr-toolchain
	$(BIN)/python benchmarks/run_all.py --write $(BENCH_DOC) $(BENCH_ARGS)

bench-doc: $(if $(BENCH_RESULTS),$(STAMP))
	@test -n "$(BENCH_RESULTS)" || { echo "usage: make bench-doc BENCH_RESULTS=DIR"; exit 2; }
	$(BIN)/python benchmarks/report.py --write $(BENCH_DOC) $(BENCH_RESULTS)

clean:
	rm -rf $(VENV) site dist build $(DEMO_OUT) .mypy_cache .ruff_cache .pytest_cache .hypothesis \
		mutants
