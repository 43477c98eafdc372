"""Code and static RAM of an S08 image from SDCC's .rel and .map files."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path


# ------------------------------------------------------------------ sizes
S08_DIRECT_PAGE_RAM = 128  # 0x80-0xff on a real part
CODE_AREAS = ("CSEG", "CONST", "HOME", "GSINIT0", "GSINIT", "GSFINAL", "XINIT", "CODEIVT0")
RAM_AREAS = ("DSEG", "OSEG", "XSEG", "XISEG")
_AREA_REL = re.compile(r"^A (\S+) size ([0-9A-Fa-f]+) ")
_AREA_MAP = re.compile(r"^(\S+)\s+([0-9A-Fa-f]{8})\s+([0-9A-Fa-f]{8}) =\s+(\d+)\. bytes")


def _linked_modules(map_path: Path) -> set:
    """Names of the modules whose symbols the linker map lists."""
    mods = set()
    for line in Path(map_path).read_text(errors="replace").splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[0] == "C:" and parts[2].startswith("_"):
            mods.add(parts[3])
        elif len(parts) == 3 and re.fullmatch(r"[0-9A-Fa-f]{8}", parts[0]):
            mods.add(parts[2])
    return mods


def _rel_areas(path) -> dict:
    out = {}
    for line in Path(path).read_text(errors="replace").splitlines():
        m = _AREA_REL.match(line)
        if m:
            out[m.group(1)] = out.get(m.group(1), 0) + int(m.group(2), 16)
    return out


@dataclass
class McuSizes:
    core_code_bytes: int  # firmware/src modules: CSEG + CONST
    core_table_bytes: int  # of which constant data (fx_atan_table)
    core_ram_bytes: int  # firmware/src modules: DSEG + OSEG + XSEG (locals are static)
    image_code_bytes: int  # whole linked image, incl. harness and SDCC helpers
    image_ram_bytes: int
    direct_page_bytes: int  # DSEG + OSEG of the image (SDCC's page-zero variables)
    fits_s08_direct_page: bool  # direct_page_bytes <= 128 (0x80-0xff on a real S08)
    per_module: dict = field(default_factory=dict)  # name -> {"code": n, "ram": n}
    library_modules: list = field(default_factory=list)  # SDCC helpers linked in


def sizes(b) -> McuSizes:
    per = {}
    for r in b.core_rels:
        a = _rel_areas(r)
        per[Path(r).stem] = {"code": sum(a.get(k, 0) for k in CODE_AREAS),
                             "const": a.get("CONST", 0),
                             "ram": sum(a.get(k, 0) for k in RAM_AREAS)}
    img = {}
    ours = {Path(r).stem for r in b.core_rels + b.other_rels}
    mods = _linked_modules(Path(b.map))
    for line in Path(b.map).read_text(errors="replace").splitlines():
        m = _AREA_MAP.match(line)
        if m:
            img[m.group(1)] = img.get(m.group(1), 0) + int(m.group(4))
    return McuSizes(
        core_code_bytes=sum(v["code"] for v in per.values()),
        core_table_bytes=sum(v["const"] for v in per.values()),
        core_ram_bytes=sum(v["ram"] for v in per.values()),
        image_code_bytes=sum(img.get(k, 0) for k in CODE_AREAS),
        image_ram_bytes=sum(img.get(k, 0) for k in RAM_AREAS),
        direct_page_bytes=img.get("DSEG", 0) + img.get("OSEG", 0),
        fits_s08_direct_page=img.get("DSEG", 0) + img.get("OSEG", 0) <= S08_DIRECT_PAGE_RAM,
        per_module=per,
        library_modules=sorted(m for m in mods - ours if m.startswith("_")),
    )
