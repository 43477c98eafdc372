"""Constants that must agree between the firmware C, the host and the
emulator: read from the firmware headers (the #define) and compared with the
Python value; Python copies of a Python constant are the same object.
"""
from __future__ import annotations

import re
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

import inclino
from inclino.procedures import acquire, accept, readings
from inclino.formats import calimage
from inclino.boot import flashing
from inclino.boot import image as boot_image
from inclino.engines import golden, reference
from inclino.link import protocol

ROOT = Path(__file__).resolve().parent.parent
INCLUDE = ROOT / "firmware" / "include" / "inclino"
DEFINE = re.compile(r"^\s*#define\s+(\w+)\s+([^/\s][^/]*?)\s*(?:/\*.*)?$")
LITERAL = re.compile(r"^(0[xX][0-9a-fA-F]+|\d+)[uUlL]*$")


def parse_defines(text: str) -> dict[str, int]:
    """Integer #defines of a header: literals (with u/L suffixes) and names of
    other integer #defines; anything else (expressions, casts) is left out."""
    raw = {}
    for line in text.splitlines():
        m = DEFINE.match(line)
        if m:
            raw[m.group(1)] = m.group(2).strip()
    out: dict[str, int] = {}
    for _ in range(3):  # aliases of aliases
        for k, v in raw.items():
            m = LITERAL.match(v)
            if m:
                out[k] = int(m.group(1), 0)
            elif v in out:
                out[k] = out[v]
    return out


@pytest.fixture(scope="module")
def C() -> dict[str, int]:
    # all headers as one text: a #define may name one of another header
    return parse_defines("\n".join(h.read_text(encoding="utf-8") for h in sorted(INCLUDE.glob("*.h"))))


def test_the_header_parser_reads_literals_suffixes_and_aliases():
    d = parse_defines("#define A 0x21u\n#define B 12u /* code */\n#define C A\n#define D 0x424F4F54UL\n"
                      "#define E ((int32_t)32768L)\n#define INCLUDE_GUARD\n")
    assert d == {"A": 0x21, "B": 12, "C": 0x21, "D": 0x424F4F54}


def test_frame_constants_match_proto_frame_h(C):
    assert protocol.SOF == C["PROTO_SOF"]
    assert protocol.VERSION == C["PROTO_VERSION"]
    assert protocol.MAX_PAYLOAD == C["PROTO_MAX_PAYLOAD"]
    assert protocol.OVERHEAD == C["PROTO_OVERHEAD"]
    assert protocol.LINE_MAX == C["PROTO_LINE_MAX"]
    assert protocol.NAK == C["PROTO_NAK"] == C["PCMD_NAK"]
    assert protocol.STREAM_FRAME == C["PCMD_STREAM_FRAME"]
    assert protocol.BOOT_KEY == C["PROTO_BOOT_KEY"]


def test_command_codes_match_proto_cmd_h(C):
    c_cmds = {k[len("PCMD_"):]: v for k, v in C.items() if k.startswith("PCMD_")}
    c_cmds.pop("NAK")
    c_cmds.pop("STREAM_FRAME")
    assert protocol.CMD == c_cmds


def test_error_codes_match_the_headers(C):
    c_err = {v: "E_" + k[len("PERR_"):] for k, v in C.items() if k.startswith("PERR_")}
    c_err[C["BOOT_E_PROTECTED"]] = "E_PROTECTED"  # the bootloader's own answer code (boot.h)
    assert protocol.ERRORS == c_err


def test_record_lengths_match_proto_cmd_h(C):
    assert protocol.SurveyRecord.FMT.size == C["PROTO_SURVEY_LEN"]
    assert protocol.RawRecord.FMT.size == C["PROTO_RAW_LEN"]
    assert protocol.Identity.FMT.size == C["PROTO_IDENTITY_LEN"]
    assert protocol.QCREF.size == C["PROTO_QCREF_LEN"]


def test_bootloader_codes_match_boot_h(C):
    assert [flashing.B_IDENTIFY, flashing.B_ERASE, flashing.B_PROGRAM, flashing.B_READ, flashing.B_CRC,
            flashing.B_COMMIT, flashing.B_RUN] == [C[f"BCMD_{n}"] for n in
                                                   ("IDENTIFY", "ERASE", "PROGRAM", "READ", "CRC", "COMMIT", "RUN")]
    assert boot_image.MAX_RANGES == C["BOOT_MAX_RANGES"]
    assert flashing.BOOT_KEY is protocol.BOOT_KEY
    assert (flashing.CMD_BOOTLOADER, flashing.CMD_IDENTIFY, flashing.CMD_STOP) == (
        C["PCMD_BOOTLOADER"], C["PCMD_IDENTIFY"], C["PCMD_STOP"])
    for n in ("COMMAND", "ARGUMENT", "BUSY", "FLASH", "IMAGE", "STATE"):
        assert getattr(flashing, f"E_{n}") == C[f"PERR_{n}"], n
    assert flashing.E_PROTECTED == C["BOOT_E_PROTECTED"]


def test_attitude_flags_match_attitude_h(C):
    c_flags = {k[len("ATT_F_"):]: v for k, v in C.items() if k.startswith("ATT_F_")}
    py_flags = {k[len("F_"):]: v for k, v in vars(golden).items() if k.startswith("F_")}
    assert py_flags == c_flags
    assert accept.NEAR_VERTICAL == C["ATT_F_NEAR_VERTICAL"]


def test_calibration_image_layout_matches_calimg_h(C):
    assert calimage.MAGIC == C["CALIMG_MAGIC"]
    assert calimage.VERSION == C["CALIMG_VERSION"]
    assert calimage.SIZE == C["CALIMG_SIZE"]
    assert calimage.CRC_OFFSET == C["CALIMG_CRC_OFFSET"]
    assert calimage.METHODS == {k[len("CALIMG_METHOD_"):].lower(): v for k, v in C.items()
                                if k.startswith("CALIMG_METHOD_")}


def test_accelerometer_scale_is_one_value():
    """The ADIS16210's LSB: the firmware's driver header states it, the host's
    reference owns it, acquisition imports it, the emulator's register model
    states the datasheet's value."""
    from inclino_emu import adis16210

    text = (INCLUDE / "adis16210.h").read_text(encoding="utf-8")
    m = re.search(r"int16_t acc\[3\];.*1 LSB = 2\^(-\d+) g", text)
    assert m, "adis16210.h no longer states the accelerometer LSB"
    assert reference.ACC_LSB_G == 2.0 ** int(m.group(1))
    assert acquire.ACC_LSB_G is reference.ACC_LSB_G and acquire.MAG_LSB_NT is reference.MAG_LSB_NT
    assert readings.ACC_LSB_G is reference.ACC_LSB_G and readings.MAG_LSB_NT is reference.MAG_LSB_NT
    assert adis16210.ACC_LSB_G == reference.ACC_LSB_G


def test_effect_names_are_one_list_and_the_library_candidates():
    from inclino import diagnose
    from inclino.diagnose import core, names

    assert diagnose.EFFECT_NAMES is names.EFFECT_NAMES is core.EFFECT_NAMES
    assert len(set(names.EFFECT_NAMES)) == len(names.EFFECT_NAMES)
    assert {c.name for c in core.all_candidates()} == set(names.EFFECT_NAMES)


def test_version_is_one_string():
    """pyproject.toml takes the version from inclino.__version__; the
    installed metadata says the same."""
    proj = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert "version" not in proj and "version" in proj["dynamic"]
    assert metadata.version("inclino") == inclino.__version__


def test_a_changed_header_code_is_caught():
    """A copy of proto_cmd.h with one command code changed no longer agrees
    with protocol.CMD (the check compares values, not names only)."""
    text = "\n".join(h.read_text(encoding="utf-8") for h in sorted(INCLUDE.glob("*.h")))
    assert "#define PCMD_STOP 0x04u" in text
    bad = parse_defines(text.replace("#define PCMD_STOP 0x04u", "#define PCMD_STOP 0x14u"))
    c_cmds = {k[len("PCMD_"):]: v for k, v in bad.items() if k.startswith("PCMD_")}
    c_cmds.pop("NAK")
    c_cmds.pop("STREAM_FRAME")
    assert c_cmds != protocol.CMD and c_cmds["STOP"] == 0x14
