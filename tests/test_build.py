"""The development install: what `make test` runs is the checkout.

The Makefile installs the project in editable mode, so Python modules and
package data are imported from the source tree; only the compiled firmware
(inclino.engines._core, inclino_emu._fw) is rebuilt, by the stamp that depends on
every C source and header. These tests fail when the suite would run an old
copy: a package imported from somewhere else, a new file under emulator/ or a
data file that a fresh interpreter does not see, or an extension older than a
C source it was built from."""
import os
import pathlib
import subprocess
import sys
import uuid

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _inside(path, folder):
    return pathlib.Path(path).resolve().is_relative_to(folder.resolve())


def test_packages_are_imported_from_the_checkout():
    import inclino
    import inclino_emu
    assert _inside(inclino.__file__, ROOT / "host" / "inclino"), inclino.__file__
    assert _inside(inclino_emu.__file__, ROOT / "emulator" / "inclino_emu"), inclino_emu.__file__


def _fresh(code):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/", timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.parametrize("package,folder", [("inclino_emu", ROOT / "emulator" / "inclino_emu"),
                                            ("inclino.diagnose", ROOT / "host" / "inclino" / "diagnose")])
def test_a_new_module_reaches_a_fresh_interpreter(package, folder):
    name = f"_reach_{uuid.uuid4().hex[:8]}"
    token = uuid.uuid4().hex
    path = folder / f"{name}.py"
    path.write_text(f"TOKEN = {token!r}\n")
    try:
        assert _fresh(f"import {package}.{name} as m; print(m.TOKEN)") == token
    finally:
        path.unlink()


@pytest.mark.parametrize("package,folder,suffix", [
    ("inclino.model.scenarios", ROOT / "host" / "inclino" / "model" / "scenarios", ".toml"),
    ("inclino.diagnose.papers_data", ROOT / "host" / "inclino" / "diagnose" / "papers_data", ".csv")])
def test_a_changed_data_file_reaches_a_fresh_interpreter(package, folder, suffix):
    name = f"_reach_{uuid.uuid4().hex[:8]}{suffix}"
    token = uuid.uuid4().hex
    path = folder / name
    path.write_text(f"# {token}\n")
    try:
        code = (f"import importlib.resources as r; "
                f"print(r.files({package!r}).joinpath({name!r}).read_text().strip())")
        assert _fresh(code) == f"# {token}"
    finally:
        path.unlink()


def _c_inputs():
    files = [p for p in (ROOT / "firmware").rglob("*") if p.suffix in (".c", ".h")]
    files += [ROOT / "host" / "inclino" / "engines" / "_build_core.py", ROOT / "emulator" / "inclino_emu" / "_build_fw.py"]
    files += [p for p in (ROOT / "host" / "inclino" / "engines").glob("_core_batch.*")]
    return files


@pytest.mark.parametrize("module", ["inclino.engines._core", "inclino_emu._fw"])
def test_compiled_firmware_is_not_older_than_its_sources(module):
    import importlib
    ext = pathlib.Path(importlib.import_module(module).__file__)
    built = ext.stat().st_mtime
    newer = sorted(str(p.relative_to(ROOT)) for p in _c_inputs() if p.stat().st_mtime > built + 1)
    assert not newer, (f"{ext.name} is older than {', '.join(newer[:5])}: run `make test` "
                       "(it rebuilds the extensions), not pytest alone")


def test_the_makefile_stamp_covers_every_compiled_input():
    """`make -n` after touching a C header must plan the reinstall."""
    header = ROOT / "firmware" / "include" / "inclino" / "fx_ops.h"
    stamp = ROOT / ".venv" / ".installed"
    if not stamp.exists():
        pytest.skip("no .venv/.installed: the suite was not started by `make test`")
    st = os.stat(header)
    try:
        os.utime(header, (st.st_atime, stamp.stat().st_mtime + 10))
        plan = subprocess.run(["make", "-n", "test"], cwd=ROOT, capture_output=True, text=True, timeout=60).stdout
    finally:
        os.utime(header, (st.st_atime, st.st_mtime))
    assert "pip install" in plan and "-e" in plan, plan
