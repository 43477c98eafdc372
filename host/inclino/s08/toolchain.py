"""The S08 toolchain: SDCC builds of the harness image (firmware/src and the
port, firmware/port/s08, from the source manifest) or of the float
baseline (tools/s08/survey_float.c), with the checks of the direct page and
the linked helpers; where the sources and the tools are."""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from inclino import fw_sources
from inclino.s08.sizes import _AREA_MAP, _linked_modules
from inclino.formats.jsonout import dumps


MISSING_REASON = ("S08 simulator tools not found (sdcc, shc08): "
                  "install the Debian packages sdcc and sdcc-ucsim")

# The harness image's files are the builds "s08_core" (the portable core and
# the port's part of it) and "s08_rig" (main() and the byte protocol) of the
# one source manifest, firmware/sources.txt (fw_sources.py).
# each port file replaces the portable C of the same functions (firmware/port/s08/*.c)
PORT_DEFINES = ("-DFX_PORT_MUL16", "-DFX_PORT_OPS", "-DFX_PORT_MUL32", "-DFX_PORT_DIV",
                "-DFX_PORT_SQRT", "-DFX_PORT_ATAN2", "-DATT_PORT_NORM3", "-DPROTO_PORT_FEED",
                "-DCORR_PORT_TEMP")
FLOAT_SOURCES = ("survey_float.c",)
SIMIF = "rom[0xff00]"
CFLAGS = ("-ms08", "--std-c99", "--opt-code-speed", "--stack-auto")
FLOAT_CFLAGS = ("-ms08", "--std-c99", "--opt-code-speed")
# SDCC keeps spill locations and its helper registers in the direct page
# (areas DSEG, OSEG).  A real S08 has registers at 0x00-0x7f and direct-page
# RAM at 0x80-0xff only.  Built with --stack-auto, the harness image keeps
# only the return registers and the port's few scratch bytes there, and its
# direct page starts at 0x80 as on a real part.  The non-reentrant float
# baseline needs more than those 128 bytes; the simulator's memory is flat,
# so its direct page starts at 0x10.  See _check_page0 for why the page must
# not overflow.
LDFLAGS = ("--data-loc", "0x80")
FLOAT_LDFLAGS = ("--data-loc", "0x10")
TIMED = 0x80
BUS_HZ = 20_000_000  # the HCS12X/S08 bus the cycle target is stated for

TARGET_SURVEY_CYCLES = 60_000
TARGET_FLOAT_RATIO = 0.25
TARGET_PARSER_CPU = 0.15  # the frame parser's share of the bus at 115 200 baud


class McuError(RuntimeError):
    pass


def tools_missing() -> str | None:
    """None when sdcc and shc08 are on PATH, else a one-line reason."""
    if shutil.which("sdcc") and shutil.which("shc08"):
        return None
    return MISSING_REASON


def repo_root() -> Path:
    """The source tree holding firmware/: $INCLINO_ROOT, the current
    directory or one of its parents, or the tree this module sits in."""
    cands = []
    if os.environ.get("INCLINO_ROOT"):
        cands.append(Path(os.environ["INCLINO_ROOT"]))
    cwd = Path.cwd().resolve()
    cands += [cwd, *cwd.parents]
    here = Path(__file__).resolve()
    cands += list(here.parents)
    for c in cands:
        if (c / "firmware" / "src" / "survey.c").is_file() and (c / "firmware" / "port" / "s08").is_dir():
            return c
    raise McuError("firmware sources not found: run from the inclino source tree or set INCLINO_ROOT")


# ------------------------------------------------------------------ build
@dataclass
class McuBuild:
    program: str  # "harness" (fixed-point core) or "float"
    workdir: str
    ihx: str
    map: str
    core_rels: list
    other_rels: list
    cflags: list
    compiled: list = field(default_factory=list)  # the sources compiled for this build (the rest: from objects)

    def to_json(self) -> str:
        return dumps(asdict(self))


def _sdcc(args, cwd):
    r = subprocess.run(["sdcc", *args], cwd=cwd, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        raise McuError(f"sdcc {' '.join(args)} failed:\n{r.stdout}\n{r.stderr}")
    return r


def _headers_digest(root: Path) -> str:
    """One digest of every header of the tree (name and bytes): what any
    source may include."""
    import hashlib

    h = hashlib.sha256()
    for f in sorted((root / "firmware").rglob("*.h")) + sorted((root / "tools").rglob("*.h")):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def build(workdir: str | os.PathLike | None = None, program: str = "harness",
          cflags: tuple | None = None, root: str | os.PathLike | None = None,
          objects: dict | None = None) -> McuBuild:
    """Compile each source with `sdcc -ms08` and link an Intel-hex image.

    program "harness": the fixed-point core (firmware/src) and the test
    harness (firmware/sim/s08), by default with CFLAGS (--stack-auto: locals
    and spill locations on the stack, not in the 128-byte direct page);
    "float": the float baseline (tools/s08/survey_float.c), by default with
    FLOAT_CFLAGS (not --stack-auto: it calls SDCC's float library, whose
    shipped build is the non-reentrant one).  A --stack-auto image that
    links any SDCC helper library module is refused (_check_helpers).

    objects: a dict shared by several builds (of copies of the tree that
    differ in a source or two): an object whose source bytes, every
    header's bytes and the flags are those of an object compiled before is
    copied instead of compiled again (McuBuild.compiled lists what was
    compiled).  The copy is that source compiled in the other tree: SDCC's
    code for a header's inline function can differ by a few bytes with the
    directory it was read from, as between any two copies of the tree."""
    if tools_missing():
        raise McuError(tools_missing())
    if cflags is None:
        cflags = FLOAT_CFLAGS if program == "float" else CFLAGS
    root = Path(root) if root else repo_root()
    wd = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix=f"inclino-s08-{program}-"))
    wd.mkdir(parents=True, exist_ok=True)
    inc = ["-I", str(root / "firmware" / "include"), "-I", str(root / "firmware" / "port" / "s08"),
           "-I", str(root / "firmware" / "sim" / "s08")]
    if program == "harness":
        inc += list(PORT_DEFINES)
    if program == "harness":
        core = fw_sources.sources("s08_core", root)
        other = fw_sources.sources("s08_rig", root)
    elif program == "float":
        core = []
        other = [root / "tools" / "s08" / s for s in FLOAT_SOURCES]
    else:
        raise ValueError(f"unknown program {program!r}")
    rels, compiled = {}, []
    headers = _headers_digest(root) if objects is not None else ""
    from glob import escape as glob_escape

    for src in core + other:
        rel = wd / (src.stem + ".rel")
        key = None
        if objects is not None:
            import hashlib

            key = (src.name, tuple(cflags), tuple(a for a in inc if a.startswith("-D")), headers,
                   hashlib.sha256(src.read_bytes()).hexdigest())
        if key is not None and key in objects and Path(objects[key]).is_file():
            done = Path(objects[key])  # the object and what the linker reads beside it (.lst, .sym, .asm)
            for f in done.parent.glob(glob_escape(done.stem) + ".*"):
                if f.suffix not in (".ihx", ".map", ".mem", ".lk", ".noi", ".cdb"):
                    shutil.copyfile(f, wd / f.name)
        else:
            _sdcc([*cflags, *inc, "-c", str(src), "-o", str(rel)], wd)
            compiled.append(src.name)
            if key is not None:
                objects[key] = str(rel)
        rels[src] = rel
    # the object with main() first: SDCC's linker takes its start-up from it
    order = [rels[s] for s in other] + [rels[s] for s in core]
    ihx = wd / f"{program}.ihx"
    ldflags = FLOAT_LDFLAGS if program == "float" else LDFLAGS
    _sdcc([*cflags, *ldflags, "--out-fmt-ihx", "-o", str(ihx), *map(str, order)], wd)
    _check_page0(ihx.with_suffix(".map"))
    if "--stack-auto" in cflags:
        _check_helpers(ihx.with_suffix(".map"), {Path(r).stem for r in rels.values()})
    return McuBuild(program, str(wd), str(ihx), str(ihx.with_suffix(".map")),
                    [str(rels[s]) for s in core], [str(rels[s]) for s in other], list(cflags), compiled)


def _check_page0(map_path: Path) -> None:
    """SDCC keeps its spill locations and helper registers in the direct
    page (areas DSEG and OSEG, from 0x80).  Past 0xff the linker silently
    wraps the 8-bit direct addresses and variables alias each other (found
    by trying: wrong G and B totals, no warning).  Refuse such an image."""
    for line in map_path.read_text(errors="replace").splitlines():
        m = _AREA_MAP.match(line)
        if m and m.group(1) in ("DSEG", "OSEG"):
            end = int(m.group(2), 16) + int(m.group(3), 16)
            if end > 0x100:
                raise McuError(f"{m.group(1)} ends at {end:#x}, beyond the direct page (0x100): "
                               "too many page-zero spill locations; simplify the code or "
                               "move data out of the direct page")


# SDCC library modules a --stack-auto image may link: start-up code and the
# return registers, no arithmetic
STACK_AUTO_SAFE_MODULES = ("_startup", "_ret")


def _check_helpers(map_path: Path, ours: set) -> None:
    """With --stack-auto, SDCC calls its helpers (__mullong, __divulong,
    __mulint, the float routines, ...) with the reentrant convention, but the
    libraries Debian ships are the non-reentrant builds: the products come
    out wrong without a link error.  The core needs none of them (fx_mul16
    is the port's own); refuse an image that links one."""
    mods = _linked_modules(map_path) - ours
    bad = sorted(m for m in mods if m not in STACK_AUTO_SAFE_MODULES)
    if bad:
        raise McuError(f"--stack-auto image links SDCC helper modules {bad}: the shipped "
                       "helpers are not reentrant; avoid the operation or rebuild the "
                       "helpers from /usr/share/sdcc/lib/src with the same flags")
