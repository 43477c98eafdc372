"""Property-based hostile-input suite (Hypothesis) for the three file parsers
a user hands the CLI: the raw dataset reader (`inclino attitude`), the
CAL.json loader (`attitude --cal`, `verify`) and the S-record image loader
(`inclino flash`).

For every generated input -- well-formed files, well-formed files with one to
three hostile mutations, random text and random bytes -- the command ends
with the exit status docs/cli.md gives (0, or 2 bad input, 3 calibration
refused, 4 no port), never with an exception; a refusal is exactly one line
on stderr starting `inclino: error:`, and nothing is written; a well-formed
file is read back exactly (values built here, not by the code under test).

Examples per property: 100 in `make test`; 10 000 with the full profile
(docs/testing.md):
    .venv/bin/python -m pytest -q -s -p no:randomly -n 0 --hypothesis-profile=full tests/test_hostile_props.py
prints, per parser, how many inputs ran and how many ended in a traceback
(INCLINO_HYPOTHESIS_EXAMPLES=N sets any other count).
"""
import collections
import contextlib
import io
import itertools
import json
import math
import os
import tempfile

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="pip install -e '.[test]' (hypothesis is a test extra)")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from inclino import cli  # noqa: E402
from inclino.formats.calfile import Calibration  # noqa: E402
from inclino.formats.dataset import MAX_LINE_CHARS, read_raw  # noqa: E402
from inclino.boot.image import load_image  # noqa: E402
from conftest import hypothesis_examples  # noqa: E402

EXAMPLES = hypothesis_examples(100)
settings.register_profile("inclino-hostile", max_examples=EXAMPLES, deadline=None, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
SETTINGS = settings.get_profile("inclino-hostile")

COUNTS = collections.defaultdict(collections.Counter)
_seq = itertools.count()


@pytest.fixture(scope="module")
def work():
    with tempfile.TemporaryDirectory(prefix="inclino-hostile-") as d:
        yield d
    lines = [f"{name}: {c['inputs']} inputs ({c['refused']} refused with one line, {c['accepted']} accepted or "
             f"stopped at the missing port, "
             f"{c['wellformed']} well-formed read back exactly), {c['tracebacks']} tracebacks"
             for name, c in sorted(COUNTS.items())]
    print(f"\nhostile inputs per parser ({EXAMPLES} examples per property):\n  " + "\n  ".join(lines))


def run_cli(argv):
    """cli.main in this process: (status, stdout, stderr); an exception
    escaping main is counted and re-raised (that is a traceback)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli.main(argv)
    return rc, out.getvalue(), err.getvalue()


def _check(parser: str, argv, allowed, refused_rc, wellformed_rc=None, output=None):
    """Run one input; refused_rc: the status of a refused file; wellformed_rc:
    the status a well-formed input must give."""
    c = COUNTS[parser]
    c["inputs"] += 1
    try:
        rc, out, err = run_cli(argv)
    except BaseException:
        c["tracebacks"] += 1
        raise
    assert rc in allowed, (rc, err)
    c["refused" if rc == refused_rc else "accepted"] += 1
    if rc == 0:
        assert "Traceback" not in err
    else:
        assert err.startswith("inclino: error: ") and err.count("\n") == 1, err
        if output is not None:
            assert not os.path.exists(output), "written on refusal"
    if wellformed_rc is not None:
        c["wellformed"] += 1
        assert rc == wellformed_rc, err
    return rc


# ------------------------------------------------------------------ mutations shared by the text formats
HOSTILE_CELLS = ["", " ", "1,5", "1_5", "nan", "NaN", "inf", "-inf", "1e999", "-1e999", "0x10", '"1"', '"',
                 "\u0661", "\uff11", "\x00", "1e-400", "+", "-", ".", "1.5.2", "\ufeff1", "１e3", "9" * 400]


def mutate_text(draw, text: str) -> bytes:
    lines = text.split("\n")
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["cell", "add_cell", "drop_cell", "comma", "line", "dup_line", "drop_line",
                                   "truncate", "bom", "crlf", "cr", "nul", "quote", "long", "bytes", "header"]))
        lines = lines or [""]
        i = draw(st.integers(0, max(0, len(lines) - 1)))
        cells = lines[i].split(",")
        j = draw(st.integers(0, max(0, len(cells) - 1)))
        if op == "cell":
            cells[j] = draw(st.one_of(st.sampled_from(HOSTILE_CELLS), st.text(max_size=8)))
        elif op == "add_cell":
            cells.insert(j, draw(st.sampled_from(HOSTILE_CELLS[:12] + ["1", "0"])))
        elif op == "drop_cell" and len(cells) > 1:
            del cells[j]
        elif op == "comma":
            cells[j] = cells[j].replace(".", ",", 1)
        elif op == "line":
            lines.insert(i, draw(st.text(max_size=40)))
        elif op == "dup_line":
            lines.insert(i, lines[i])
        elif op == "drop_line":
            del lines[i]
            continue
        elif op == "truncate":
            text = "\n".join(lines)
            lines = text[:draw(st.integers(0, len(text)))].split("\n")
            continue
        elif op == "bom":
            lines[0] = "\ufeff" + lines[0]
            continue
        elif op == "crlf":
            lines = [ln + "\r" for ln in lines]
            continue
        elif op == "cr":
            lines = ["\r".join(lines)]
            continue
        elif op == "nul":
            cells[j] += "\x00"
        elif op == "quote":
            cells[j] = '"' + cells[j]
        elif op == "long":
            cells[j] += "7" * (MAX_LINE_CHARS + 1)
        elif op == "bytes":
            raw = "\n".join(lines).encode("utf-8", "surrogatepass")
            k = draw(st.integers(0, len(raw)))
            return raw[:k] + draw(st.binary(min_size=1, max_size=8)) + raw[k:]
        elif op == "header":
            lines.insert(0, draw(st.sampled_from(["# field_nT=-50000", "# dip_deg=500", "# field_nT=nan",
                                                  "# gravity_g=1e999", "# dip_deg=", "#", "# lat_deg=91"])))
            continue
        if lines:
            lines[i] = ",".join(cells)
    return "\n".join(lines).encode("utf-8", "surrogatepass")


# ------------------------------------------------------------------ the dataset reader
COLS = {"t_s": (0, 1e5), "inc_deg": (0, 180), "azi_deg": (0, 359.99), "tf_deg": (0, 359.99), "temp_c": (-40, 150),
        "ax_g": (-1.7, 1.7), "ay_g": (-1.7, 1.7), "az_g": (-1.7, 1.7),
        "mx_nT": (-1e5, 1e5), "my_nT": (-1e5, 1e5), "mz_nT": (-1e5, 1e5)}
SENSORS = ["ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT"]


@st.composite
def datasets(draw):
    optional = draw(st.lists(st.sampled_from(["t_s", "inc_deg", "azi_deg", "tf_deg", "temp_c"]), unique=True))
    cols = draw(st.permutations(SENSORS + optional))
    extra = draw(st.booleans())
    n = draw(st.integers(1, 12))
    values = {c: [draw(st.floats(*COLS[c], allow_nan=False)) for _ in range(n)] for c in cols}
    meta = {}
    if draw(st.booleans()):
        meta["field_nT"] = draw(st.floats(20000, 70000))
        meta["dip_deg"] = draw(st.floats(-90, 90))
    head = "".join(f"# {k}={v!r}\n" for k, v in meta.items())
    header = cols + (["note"] if extra else [])
    rows = [",".join([repr(values[c][r]) for c in cols] + (["x y"] if extra else [])) for r in range(n)]
    return head + ",".join(header) + "\n" + "\n".join(rows) + "\n", values, meta


@st.composite
def hostile_datasets(draw):
    kind = draw(st.sampled_from(["wellformed", "mutated", "mutated", "mutated", "text", "bytes"]))
    if kind == "text":
        return draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"), None
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    text, values, meta = draw(datasets())
    if kind == "wellformed":
        return text.encode(), (values, meta)
    return mutate_text(draw, text), None


@SETTINGS
@given(case=hostile_datasets())
def test_dataset_reader_never_tracebacks(work, case):
    data, expected = case
    k = next(_seq)
    src, out = os.path.join(work, f"d{k}.csv"), os.path.join(work, f"d{k}.out.csv")
    with open(src, "wb") as f:
        f.write(data)
    rc = _check("dataset reader (attitude)", ["attitude", src, "-o", out], (0, 2), 2, 0 if expected is not None else None, out)
    if expected is not None:
        values, meta = expected
        ds = read_raw(src)
        for c, v in values.items():
            assert ds.columns[c].tolist() == v
        assert {k: ds.meta[k] for k in meta} == meta
        with open(out) as f:
            assert sum(1 for _ in f) == len(values["ax_g"]) + 1
    if rc == 0:
        os.unlink(out)
    os.unlink(src)


# ------------------------------------------------------------------ the CAL.json loader
def _matrix(draw, scale):
    return (np.eye(3) + np.array(draw(st.lists(st.floats(-scale, scale), min_size=9, max_size=9))).reshape(3, 3)).tolist()


@st.composite
def calibrations(draw):
    return Calibration(acc_m=_matrix(draw, 0.05), acc_b=draw(st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3)),
                       mag_m=_matrix(draw, 0.05), mag_b=draw(st.lists(st.floats(-2000, 2000), min_size=3, max_size=3)),
                       method=draw(st.sampled_from(["joint", "li2021", "x"])), probe_serial=draw(st.text(max_size=6)))


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**40), 10**40) | st.floats() | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=12)


@st.composite
def hostile_calfiles(draw):
    kind = draw(st.sampled_from(["wellformed", "value", "value", "text", "text", "deep", "bytes"]))
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    cal = draw(calibrations())
    text = cal.to_json()
    if kind == "wellformed":
        return text.encode(), cal
    if kind == "deep":
        depth = draw(st.integers(20, 5000))
        at = draw(st.integers(0, len(text)))
        return (text[:at] + "[" * depth + "0" + "]" * draw(st.integers(0, depth)) + text[at:]).encode(), None
    if kind == "value":  # one field (or one element of it) replaced by any JSON value
        d = json.loads(text)
        key = draw(st.sampled_from(sorted(d) + ["fixed.acc_m", "fixed.mag_b", "acc_m.0", "mag_b.2"]))
        val = draw(JSON_VALUES | st.sampled_from([1e999, -1e999, math.nan, 10**400, 2**31, -(2**31) - 1, 0.5]))
        tgt, _, sub = key.partition(".")
        if sub and isinstance(d.get(tgt), (dict, list)):
            container = d[tgt]
            k2 = int(sub) if isinstance(container, list) else sub
            container[k2] = val
        else:
            d[key] = val
        return json.dumps(d).encode(), None
    return mutate_text(draw, text.replace(", ", ",")), None


@pytest.fixture(scope="module")
def small_run(work):
    p = os.path.join(work, "small.csv")
    with open(p, "w") as f:
        f.write("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0,0,1,20000,0,40000\n0.5,0,0.8,0,20000,40000\n")
    return p


@SETTINGS
@given(case=hostile_calfiles(), command=st.sampled_from(["attitude", "verify"]))
def test_calfile_loader_never_tracebacks(work, small_run, case, command):
    data, cal = case
    k = next(_seq)
    src, out = os.path.join(work, f"c{k}.json"), os.path.join(work, f"c{k}.out.csv")
    with open(src, "wb") as f:
        f.write(data)
    if command == "attitude":
        _check("CAL.json loader", ["attitude", small_run, "--cal", src, "-o", out], (0, 3), 3,
               0 if cal is not None else None, out)
    else:  # the file is checked before the port is opened: 3, or 4 for the missing port
        _check("CAL.json loader", ["verify", "--port", os.path.join(work, "no-port"), "--cal", src], (3, 4), 3,
               4 if cal is not None else None)
    if cal is not None:
        assert Calibration.load(src).to_fixed() == cal.to_fixed()
    if os.path.exists(out):
        os.unlink(out)
    os.unlink(src)


# ------------------------------------------------------------------ the S-record image loader
APP = (0x700000, 0x79F000)  # inside the application area of the MC9S12XEP100 flash map (docs/flash.md)


def srec(kind: int, addr: int, data: bytes = b"") -> str:
    alen = {0: 2, 1: 2, 2: 3, 3: 4, 5: 2, 7: 4, 8: 3, 9: 2}[kind]
    body = addr.to_bytes(alen, "big") + data
    count = len(body) + 1
    csum = 0xFF - ((count + sum(body)) & 0xFF)
    return f"S{kind}{count:02X}{body.hex().upper()}{csum:02X}"


@st.composite
def images(draw):
    n = draw(st.integers(1, 5))
    starts = sorted(draw(st.lists(st.integers(0, (APP[1] - APP[0]) // 64 - 1), min_size=n, max_size=n,
                                  unique=True)))
    mem = {}
    lines = [srec(0, 0, b"inclino")] if draw(st.booleans()) else []
    for s in starts:
        addr = APP[0] + 64 * s
        data = draw(st.binary(min_size=1, max_size=32))
        if s == starts[0]:  # the entry point: code there (an erased 0xFF byte is no code, boot/image.py check_entry)
            data = bytes([draw(st.integers(0, 0xFE))]) + data[1:]
        mem.update({addr + i: b for i, b in enumerate(data)})
        lines.append(srec(2, addr, data))
    entry = APP[0] + 64 * starts[0]
    lines.append(srec(8, entry))
    return "\n".join(lines) + "\n", mem


@st.composite
def hostile_images(draw):
    kind = draw(st.sampled_from(["wellformed", "mutated", "mutated", "mutated", "hex", "outside", "bytes"]))
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    if kind == "hex":  # records of any type with well-formed hex and checksums
        lines = [srec(draw(st.sampled_from([0, 1, 2, 3, 5, 7, 8, 9])), draw(st.integers(0, 0xFFFF)),
                      draw(st.binary(max_size=40))) for _ in range(draw(st.integers(0, 4)))]
        return ("\n".join(lines) + "\n").encode(), None
    if kind == "outside":  # checksummed data anywhere in the 32-bit space
        addr = draw(st.integers(0, 2**32 - 64))
        return (srec(3, addr, draw(st.binary(min_size=1, max_size=40))) + "\n" + srec(7, addr) + "\n").encode(), None
    text, mem = draw(images())
    if kind == "wellformed":
        return text.encode(), mem
    lines = text.split("\n")
    i = draw(st.integers(0, max(0, len(lines) - 2)))
    op = draw(st.sampled_from(["char", "checksum", "type", "count", "truncate", "lower", "space", "text"]))
    ln = lines[i]
    if op == "char" and len(ln) > 2:
        j = draw(st.integers(2, len(ln) - 1))
        ln = ln[:j] + draw(st.sampled_from("0123456789ABCDEFGxz \x00\u00e9")) + ln[j + 1:]
    elif op == "checksum":
        ln = ln[:-2] + f"{(int(ln[-2:], 16) + draw(st.integers(1, 255))) & 0xFF:02X}"
    elif op == "type":
        ln = "S" + draw(st.sampled_from("0123456789ABS")) + ln[2:]
    elif op == "count":
        ln = ln[:2] + f"{draw(st.integers(0, 255)):02X}" + ln[4:]
    elif op == "truncate":
        ln = ln[:draw(st.integers(0, len(ln)))]
    elif op == "lower":
        ln = ln.lower()
    elif op == "space":
        ln = " ".join(ln)
    else:
        ln = draw(st.text(max_size=40))
    lines[i] = ln
    return "\n".join(lines).encode("utf-8", "surrogatepass"), None


@SETTINGS
@given(case=hostile_images())
def test_srecord_loader_never_tracebacks(work, case):
    data, mem = case
    k = next(_seq)
    src = os.path.join(work, f"i{k}.s19")
    with open(src, "wb") as f:
        f.write(data)
    # the image is checked before the port is opened: 2 refused, 4 for the missing port
    _check("S-record loader (flash)", ["flash", src, "--port", os.path.join(work, "no-port")], (2, 4), 2,
           4 if mem is not None else None)
    if mem is not None:
        image = load_image(src)
        got = {r.addr + i: b for r in image.ranges for i, b in enumerate(r.data)}
        assert all(got[a] == b for a, b in mem.items())
        assert all(b == 0xFF for a, b in got.items() if a not in mem)  # padding is erased flash
    os.unlink(src)
