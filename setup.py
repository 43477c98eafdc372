# setuptools needs setup.py only for cffi_modules: `pip install .` compiles
# firmware/src/*.c into the inclino._core extension (cffi API, out-of-line),
# and the firmware application with the emulator's HAL into inclino_emu._fw.
from setuptools import setup

# build_ext force: distutils reuses an object file when its .c is older than
# the .o, without looking at the headers, so a changed struct in a header
# would otherwise leave stale objects with the old layout in the extension.
setup(options={"build_ext": {"force": True}},
      cffi_modules=["host/inclino/engines/_build_core.py:ffibuilder",
                    "emulator/inclino_emu/_build_fw.py:ffibuilder"])
