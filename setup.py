# setuptools needs setup.py only for cffi_modules: `pip install .` compiles
# firmware/src/*.c into the inclino._core extension (cffi API, out-of-line).
from setuptools import setup

setup(cffi_modules=["host/inclino/_build_core.py:ffibuilder"])
