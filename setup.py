# setuptools needs setup.py only for cffi_modules: `pip install .` compiles
# firmware/src/*.c into the inclino._core extension (cffi API, out-of-line),
# and the firmware application with the emulator's HAL into inclino_emu._fw.
from setuptools import setup

setup(cffi_modules=["host/inclino/_build_core.py:ffibuilder", "emulator/_build_fw.py:ffibuilder"])
