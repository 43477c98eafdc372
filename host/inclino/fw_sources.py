"""The firmware source manifest (firmware/sources.txt) for the Python builds.

Every build that compiles firmware C -- the cffi modules inclino.engines._core
(_build_core.py) and inclino_emu._fw (emulator/inclino_emu/_build_fw.py), the S08 image
(mcu.py) -- takes its file list from here, as CMakeLists.txt does through
firmware/sources.cmake, so the lists cannot drift apart.  The cffi build
scripts load this file by path (they run before the package is installed):
it imports nothing but the standard library."""
from __future__ import annotations

from pathlib import Path

MANIFEST = Path("firmware") / "sources.txt"


class ManifestError(ValueError):
    pass


def read_manifest(root: str | Path) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """(groups, builds) of ROOT/firmware/sources.txt: group -> paths relative
    to firmware/, build -> group names, both in file order."""
    path = Path(root) / MANIFEST
    groups: dict[str, list[str]] = {}
    builds: dict[str, list[str]] = {}
    for no, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        if line[0] == "build":
            if len(line) < 3 or line[1] in builds:
                raise ManifestError(f"{path}:{no}: expected 'build NAME GROUP...', once per name")
            builds[line[1]] = line[2:]
        elif len(line) == 2:
            groups.setdefault(line[0], []).append(line[1])
        else:
            raise ManifestError(f"{path}:{no}: expected 'GROUP PATH' or 'build NAME GROUP...'")
    for name, gs in builds.items():
        for g in gs:
            if g not in groups:
                raise ManifestError(f"{path}: build {name} names unknown group {g}")
    return groups, builds


def sources(build: str, root: str | Path) -> list[Path]:
    """The C files build BUILD compiles, absolute, in manifest order."""
    groups, builds = read_manifest(root)
    if build not in builds:
        raise ManifestError(f"{Path(root) / MANIFEST}: no build named {build}")
    fw = Path(root).resolve() / "firmware"
    return [fw / p for g in builds[build] for p in groups[g]]
