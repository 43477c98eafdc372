# Two commands do all the set-up (README):
#   make demo   - the main job: the whole calibration bench on the emulated probe
#   make test   - the whole test suite
# Each creates and fills the local virtual environment .venv when it is
# missing. The project is installed in editable (development) mode: the Python
# packages host/inclino and emulator/inclino_emu and their data files (scenarios, the
# papers' tables) are imported straight from the checkout, so every change to
# them is what the next command runs. Only the compiled parts, the firmware C
# in the inclino._core and inclino_emu._fw extensions, need a rebuild: the
# stamp below depends on every C source and header, the cffi build scripts and
# the packaging files, and `pip install -e` rebuilds both extensions in place.

PY ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SOURCES := $(shell find firmware host emulator \( -name '*.c' -o -name '*.h' -o -name '_build_*.py' -o -name sources.txt -o -name fw_sources.py -o -name fw_cdef.py \) -not -path '*/__pycache__/*' 2>/dev/null) \
           pyproject.toml setup.py Makefile

.PHONY: demo test clean

$(STAMP): $(SOURCES)
	@test -x $(VPY) || $(PY) -m venv $(VENV)
	@$(VPY) -m pip install -qq --upgrade pip
	@echo "installing inclino (editable) and compiling the firmware C into .venv"
	@$(VPY) -m pip install -qq -e '.[test]'
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/inclino demo

# the whole suite on every core (pytest-xdist, one module at a time per worker,
# the modules with heavy tests first: tests/conftest.py), in a random order whose
# seed is printed at the end; PYTEST_ARGS adds options (docs/testing.md), e.g.
#   make test PYTEST_ARGS="-p randomly --randomly-seed=N --durations=20"
PYTEST_ARGS ?=
test: $(STAMP)
	$(VPY) -m pytest -q -n auto --dist loadscope --no-loadscope-reorder $(PYTEST_ARGS)

clean:
	rm -rf $(VENV) build *.egg-info host/*.egg-info host/inclino/engines/_core.c host/inclino/engines/*.so emulator/inclino_emu/_fw.c emulator/inclino_emu/*.so
