# Two commands do all the set-up (README):
#   make demo   - the main job: the whole calibration bench on the emulated probe
#   make test   - the whole test suite
# Each creates and fills the local virtual environment .venv when it is
# missing or older than the sources.

PY ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SOURCES := $(shell find firmware host -name '*.c' -o -name '*.h' -o -name '*.py' 2>/dev/null) pyproject.toml setup.py

.PHONY: demo test clean

$(STAMP): $(SOURCES)
	@test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet '.[test]'
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/inclino demo

test: $(STAMP)
	$(VPY) -m pytest -q

clean:
	rm -rf $(VENV) build *.egg-info host/*.egg-info
