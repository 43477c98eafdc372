"""The one firmware source manifest (firmware/sources.txt): each of the four
builds that compile firmware C -- CMake, the cffi modules inclino.engines._core and
inclino_emu._fw, the S08 simulator image -- takes its file list from it, and
every C file of the core, the application, the bootloader and the S08 port is
in it exactly once."""
from __future__ import annotations

import importlib.util
import shutil
import subprocess
from pathlib import Path

import pytest

from inclino import fw_sources
from inclino.s08 import toolchain as s08_toolchain

ROOT = Path(__file__).resolve().parents[1]
FW = ROOT / "firmware"


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _cffi_sources(script: Path, name: str) -> list[Path]:
    ffib = _load(script, name).ffibuilder
    srcs = ffib._assigned_source[3]["sources"]  # (module, source, ext, kwds)
    return [Path(s).resolve() for s in srcs if Path(s).resolve().is_relative_to(FW)]


def test_every_firmware_c_file_is_listed_once_and_exists():
    groups, builds = fw_sources.read_manifest(ROOT)
    listed = [p for ps in groups.values() for p in ps]
    assert len(listed) == len(set(listed)), "a file is in two groups"
    for p in listed:
        assert (FW / p).is_file(), p
    on_disk = {str(p.relative_to(FW)) for d in ("src", "port/s08", "sim/s08") for p in (FW / d).glob("*.c")}
    assert on_disk == set(listed)
    used = {g for gs in builds.values() for g in gs}
    assert used == set(groups), "a group no build compiles"


def test_the_cffi_builds_compile_the_manifest():
    assert _cffi_sources(ROOT / "host" / "inclino" / "engines" / "_build_core.py", "_t_core") == \
        fw_sources.sources("cffi_core", ROOT)
    assert _cffi_sources(ROOT / "emulator" / "inclino_emu" / "_build_fw.py", "_t_fw") == \
        fw_sources.sources("cffi_fw", ROOT)


def _s08_compiled(monkeypatch, tmp_path, root) -> list[Path]:
    """The files inclino.s08.toolchain.build hands to sdcc -c, without running sdcc."""
    seen = []

    def fake_sdcc(args, cwd):
        if "-c" in args:
            seen.append(Path(args[args.index("-c") + 1]).resolve())

    monkeypatch.setattr(s08_toolchain, "tools_missing", lambda: None)
    monkeypatch.setattr(s08_toolchain, "_sdcc", fake_sdcc)
    monkeypatch.setattr(s08_toolchain, "_check_page0", lambda p: None)
    monkeypatch.setattr(s08_toolchain, "_check_helpers", lambda p, ours: None)
    s08_toolchain.build(tmp_path / "b", root=root)
    return seen


def test_the_s08_build_compiles_the_manifest(monkeypatch, tmp_path):
    want = fw_sources.sources("s08_core", ROOT) + fw_sources.sources("s08_rig", ROOT)
    assert sorted(_s08_compiled(monkeypatch, tmp_path, ROOT)) == sorted(want)
    # and it follows the manifest: a copy of the tree without one core file
    # compiles one file less
    copy = tmp_path / "tree"
    shutil.copytree(FW, copy / "firmware")
    man = copy / "firmware" / "sources.txt"
    man.write_text(man.read_text().replace(
        "core  src/correct.c\n", ""))
    got = _s08_compiled(monkeypatch, tmp_path, copy)
    assert "correct.c" not in {p.name for p in got} and len(got) == len(want) - 1


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_cmake_compiles_the_manifest(tmp_path):
    cml = (ROOT / "CMakeLists.txt").read_text()
    assert "inclino_fw_sources(cmake INCLINO_CORE_SOURCES)" in cml
    assert ".c\n" not in cml.split("add_library")[0].replace("sources.cmake", ""), \
        "a hand-kept .c list before add_library"
    script = tmp_path / "print.cmake"
    script.write_text(f'include("{FW}/sources.cmake")\ninclino_fw_sources(cmake L)\n'
                      'foreach(f IN LISTS L)\n  message("${f}")\nendforeach()\n')
    r = subprocess.run(["cmake", "-P", str(script)], capture_output=True, text=True, check=True)
    got = [(ROOT / line).resolve() for line in r.stderr.split()]
    assert got == fw_sources.sources("cmake", ROOT)
