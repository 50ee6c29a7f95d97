# kontur: `make demo` and `make test` set up what is missing on a fresh machine, then run.
#   SIM=icarus | SIM=verilator   run the cocotb tests on one simulator (default: both)
#   WAVES=1                       dump waveforms of the tests into build/waves
#   make bitstream BOARD=icebreaker|icebreaker-z|ulx3s [MACHINE=FILE.toml] [SEED=N] the controller's bitstream
SHELL   := /bin/bash
PYTHON  ?= python3
VENV    ?= .venv
BIN     := $(VENV)/bin
SIM     ?=
WAVES   ?= 0
JOBS    ?= auto
BOARD   ?= icebreaker
SUDO    := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
STAMP   := $(VENV)/.installed

.PHONY: setup demo test test-fast formal bench bitstream clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,fpga,formal]'
	touch $@

.PHONY: icarus
icarus:                  # Icarus Verilog, and ccache (every Verilator build compiles the same
                         # runtime: sim/runners.py verilator_environment)
	@command -v iverilog >/dev/null && command -v ccache >/dev/null || { \
	    $(SUDO) apt-get update -qq && $(SUDO) apt-get install -y -qq iverilog ccache; }

.PHONY: rs274
rs274:                   # LinuxCNC's interpreter, the judge of tests/test_gcode_rs274.py
	@command -v rs274 >/dev/null || { $(SUDO) apt-get update -qq && \
	    $(SUDO) apt-get install -y -qq linuxcnc-uspace; }

setup: $(STAMP) icarus rs274

demo: setup
	$(BIN)/kontur demo

test: setup formal        # the proofs first, then everything else (waveform regression included)
	SIM=$(SIM) WAVES=$(WAVES) PYTHONWARNINGS=error $(BIN)/python -m pytest -n $(JOBS) tests \
	    -m "not formal"

formal: setup            # the SymbiYosys proofs and the broken cores' failures (docs/formal.md)
	PYTHONWARNINGS=error $(BIN)/python -m pytest -n $(JOBS) tests -m formal

test-fast: setup         # Amaranth simulator and models only, no cocotb, no proofs
	PYTHONWARNINGS=error $(BIN)/python -m pytest -n $(JOBS) tests -m "not cocotb and not formal"

bench: setup            # writes BENCHMARKS.md from one run (half an hour on 2 idle cores)
	PYTHONWARNINGS=error $(BIN)/python -m kontur.bench report --out BENCHMARKS.md

bitstream: setup         # the controller for BOARD (icebreaker, icebreaker-z, ulx3s) and MACHINE; never programs
	$(BIN)/kontur build --board $(BOARD) --top controller $(if $(MACHINE),--machine $(MACHINE))$(if $(SEED), --seed $(SEED))

clean:
	rm -rf build sim_build .pytest_cache
