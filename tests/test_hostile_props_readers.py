"""Property-based hostile input (Hypothesis) for every reader the first
round's suite (tests/test_hostile_props.py: dataset, CAL.json version 1,
S-records) did not cover: the survey listing as CSV, JSON and LAS, the
noise file, the reference-field file, the tool model, the scenario, and
CAL.json version 2 (the temperature block and its fixed-point image).

For every generated input -- a well-formed file built here (values chosen
by the test, not by the code under test), the same file with one to three
hostile mutations, a field replaced by any JSON value, deep nesting, huge
integers, random text or random bytes -- the reader returns or raises an
InclinoError whose exit status is the documented one (2 bad input, 3 a
calibration refused) and whose text is one line without Python internals;
anything else is a traceback and fails.  A well-formed file is read back
exactly.

Examples per property (each reader, and each format of the survey listing
and the noise file, its own property): 60 in `make test`; 10 000 with the
full profile (docs/testing.md):
    .venv/bin/python -m pytest -q -s -p no:randomly -n 0 --hypothesis-profile=full \\
        tests/test_hostile_props_readers.py
prints, per reader, how many inputs ran, were refused, were read back, and
ended in a traceback (INCLINO_HYPOTHESIS_EXAMPLES=N sets any other count).
"""
import collections
import itertools
import json
import math
import os
import re
import tempfile

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="pip install -e '.[test]' (hypothesis is a test extra)")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from inclino.errors import CalibrationError, DataError, InclinoError  # noqa: E402
from test_hostile_props import mutate_text  # noqa: E402
from conftest import hypothesis_examples  # noqa: E402

EXAMPLES = hypothesis_examples(60)
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.function_scoped_fixture])
COUNTS = collections.defaultdict(collections.Counter)
_seq = itertools.count()
INTERNALS = re.compile(r"Traceback|could not convert|NoneType|invalid literal|object has no attribute|unhashable|"
                       r"not subscriptable|codec can't|dtype|index out of range|takes \d+ positional")


@pytest.fixture(scope="module")
def work():
    with tempfile.TemporaryDirectory(prefix="inclino-hostile-readers-") as d:
        yield d
    lines = [f"{name}: {c['inputs']} inputs ({c['refused']} refused with one line, {c['accepted']} read, "
             f"{c['wellformed']} well-formed read back exactly), {c['tracebacks']} tracebacks"
             for name, c in sorted(COUNTS.items())]
    print(f"\nhostile inputs per reader ({EXAMPLES} examples per property):\n  " + "\n  ".join(lines))


def _file(work, data: bytes, suffix: str) -> str:
    p = os.path.join(work, f"f{next(_seq)}{suffix}")
    with open(p, "wb") as f:
        f.write(data)
    return p


def check(reader: str, fn, path: str, status: int, wellformed: bool):
    """Run a reader on a file: its value, or None when it refused the file
    with one line and the documented status."""
    c = COUNTS[reader]
    c["inputs"] += 1
    try:
        v = fn(path)
    except InclinoError as e:
        text = str(e)
        assert e.exit_code == status, (reader, type(e).__name__, text)
        assert "\n" not in text and text and not INTERNALS.search(text), text
        assert not wellformed, f"a well-formed file refused: {text}"
        c["refused"] += 1
        return None
    except BaseException:
        c["tracebacks"] += 1
        raise
    finally:
        os.unlink(path)
    c["accepted"] += 1
    if wellformed:
        c["wellformed"] += 1
    return v


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**40), 10**40) | st.floats() | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=12)
HOSTILE_VALUES = JSON_VALUES | st.sampled_from([1e999, -1e999, math.nan, 10**400, 2**31, -1, 0, 1e300, "", "x"])


def _replace_value(draw, d: dict, keys) -> dict:
    """One field (or one element/member of it) replaced by any JSON value."""
    key = draw(st.sampled_from(sorted(keys)))
    val = draw(HOSTILE_VALUES)
    tgt, _, sub = key.partition(".")
    if sub and isinstance(d.get(tgt), dict):
        d[tgt][sub] = val
    elif sub and isinstance(d.get(tgt), list) and d[tgt]:
        d[tgt][int(sub) % len(d[tgt])] = val
    else:
        d[key] = val
    return d


def _deep(draw, text: str) -> str:
    depth = draw(st.integers(20, 100000))
    at = draw(st.integers(0, len(text)))
    return text[:at] + "[" * depth + "0" + "]" * draw(st.integers(0, depth)) + text[at:]


def _bigint(draw, text: str) -> str:
    m = list(re.finditer(r"-?\d+(\.\d+)?", text))
    if not m:
        return text
    k = m[draw(st.integers(0, len(m) - 1))]
    return text[:k.start()] + "9" * draw(st.integers(31, 6000)) + text[k.end():]


# ------------------------------------------------------------ survey listings
@st.composite
def stations(draw, min_n=2, fields=None):
    """Stations as a listing has them; `fields` True/False forces the field
    columns (gt_g, bt_nT, dip_deg) in or out, None draws it."""
    n = draw(st.integers(min_n, 15))
    md = np.cumsum([0.0] + [draw(st.floats(0.5, 200.0)) for _ in range(n - 1)])
    inc = [draw(st.floats(0.0, 180.0)) for _ in range(n)]
    azi = [draw(st.floats(0.0, 359.999)) for _ in range(n)]
    extra = {}
    if draw(st.booleans()) if fields is None else fields:
        extra = {"gt_g": [draw(st.floats(0.9, 1.1)) for _ in range(n)],
                 "bt_nT": [draw(st.floats(30000, 70000)) for _ in range(n)],
                 "dip_deg": [draw(st.floats(-89, 89)) for _ in range(n)]}
    return [round(float(x), 4) for x in md], [round(x, 6) for x in inc], [round(x, 6) for x in azi], \
        {k: [round(x, 6) for x in v] for k, v in extra.items()}


def _csv(md, inc, azi, extra, bom=False):
    cols = {"md_m": md, "inc_deg": inc, "azi_deg": azi, **extra}
    lines = [",".join(cols)] + [",".join(repr(cols[c][i]) for c in cols) for i in range(len(md))]
    return ("\ufeff" if bom else "") + "\n".join(lines) + "\n"


def _jsonl(md, inc, azi, extra, array=False):
    rows = [{"md_m": md[i], "inc_deg": inc[i], "azi_deg": azi[i], **{k: v[i] for k, v in extra.items()}}
            for i in range(len(md))]
    return json.dumps(rows) if array else "\n".join(json.dumps(r) for r in rows) + "\n"


def _las(md, inc, azi, extra):
    curves = {"DEPT": ("M", md), "INC": ("deg", inc), "AZI": ("deg", azi)}
    for k, m in (("gt_g", "GTOT"), ("bt_nT", "BTOT"), ("dip_deg", "DIP")):
        if k in extra:
            curves[m] = ("", extra[k])
    head = ["~Version", " VERS. 2.0 : CWLS LOG ASCII STANDARD - VERSION 2.0", " WRAP. NO : one line per depth",
            "~Well", f" STRT.M {md[0]!r} :", f" STOP.M {md[-1]!r} :", " STEP.M 0 :", " NULL. -999.25 :",
            "~Curve"] + [f" {m}.{u} : {m}" for m, (u, _) in curves.items()] + ["~A"]
    rows = [" ".join(repr(v[i]) for _, v in curves.values()) for i in range(len(md))]
    return "\n".join(head + rows) + "\n"


def _survey_case(draw, fmt, stations_st=None):
    md, inc, azi, extra = draw(stations_st if stations_st is not None else stations())
    bom = draw(st.booleans())
    text = {"csv": lambda: _csv(md, inc, azi, extra, bom), "json": lambda: _jsonl(md, inc, azi, extra,
                                                                                  draw(st.booleans())),
            "las": lambda: _las(md, inc, azi, extra)}[fmt]()
    kind = draw(st.sampled_from(["wellformed", "mutated", "mutated", "mutated", "deep", "bigint", "text", "bytes"]))
    if kind == "wellformed":
        return text.encode("utf-8"), (md, inc, azi)
    if kind == "text":
        return draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"), None
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    if kind == "deep":
        return _deep(draw, text).encode(), None
    if kind == "bigint":
        return _bigint(draw, text).encode(), None
    return mutate_text(draw, text.replace(", ", ",")), None


@st.composite
def survey_files(draw, fmt):
    data, expected = _survey_case(draw, fmt)
    return data, expected


@pytest.mark.parametrize("fmt", ["csv", "json", "las"])
@SETTINGS
@given(data=st.data())
def test_survey_listing_reader(work, fmt, data):
    from inclino.survey import wellpath as wp

    data, expected = data.draw(survey_files(fmt))
    path = _file(work, data, "." + fmt)
    sv = check(f"survey listing ({fmt})", wp.read_survey, path, 2, expected is not None)
    if expected is not None:
        md, inc, azi = expected
        keep = np.unique(md, return_index=True)[1]  # repeated depths are merged (one station)
        if len(keep) == len(md):
            assert np.array_equal(sv.md_m, md) and np.allclose(sv.inc_deg, inc, rtol=0, atol=1e-9)
            assert np.allclose(np.mod(sv.azi_mag_deg, 360), np.mod(azi, 360), rtol=0, atol=1e-9)


# The noise file's documented rule (docs/survey.md, toolmodel --noise): at
# least NOISE_MIN_SURVEYS surveys with gt_g and bt_nT. A well-formed file
# follows it; a file with fewer, or without the field columns, must be
# refused (one line, exit 2).
NOISE_MIN_SURVEYS = 3


@st.composite
def noise_files(draw, fmt):
    kind = draw(st.sampled_from(["run", "run", "run", "few", "nofield"]))
    if kind == "run":
        return _survey_case(draw, fmt, stations(min_n=NOISE_MIN_SURVEYS, fields=True)) + (False,)
    md, inc, azi, extra = draw(stations(min_n=1, fields=kind == "few"))
    if kind == "few":
        k = draw(st.integers(1, NOISE_MIN_SURVEYS - 1))
        md, inc, azi, extra = md[:k], inc[:k], azi[:k], {c: v[:k] for c, v in extra.items()}
    text = _csv(md, inc, azi, extra) if fmt == "csv" else _jsonl(md, inc, azi, extra, draw(st.booleans()))
    return text.encode(), None, True


@pytest.mark.parametrize("fmt", ["csv", "json"])
@SETTINGS
@given(data=st.data())
def test_noise_file_reader(work, fmt, data):
    from inclino.survey import errormodel as em
    from inclino.survey import wellpath as wp

    data, expected, must_refuse = data.draw(noise_files(fmt))

    def read(path):
        return em.noise_from_survey(wp.read_survey_rows(path))
    path = _file(work, data, "." + fmt)
    got = check(f"noise file ({fmt})", read, path, 2, expected is not None)
    assert not (must_refuse and got is not None), "a noise file below the documented rule was read"
    if expected is not None:
        assert all(math.isfinite(v) and v >= 0 for v in got)


# ------------------------------------------------------------ the reference file
@st.composite
def reference_files(draw):
    from inclino.survey.geomag import ReferenceField

    rf = ReferenceField(declination_deg=draw(st.floats(-180, 180)), dip_deg=draw(st.floats(-90, 90)),
                        field_nT=draw(st.floats(1000, 100000)), gravity_g=draw(st.floats(0.9, 1.1)),
                        ref_source=draw(st.sampled_from(["user", "IGRF (ppigrf 2.1)"])))
    if draw(st.booleans()):
        rf.lat_deg, rf.lon_deg = draw(st.floats(-89, 89)), draw(st.floats(-180, 180))
        rf.date = draw(st.dates(min_value=__import__("datetime").date(1950, 1, 1))).isoformat()
    if draw(st.booleans()):
        rf.grid_epsg, rf.convergence_deg, rf.scale_factor = 32632, draw(st.floats(-5, 5)), draw(st.floats(0.99, 1.01))
        rf.easting_m, rf.northing_m = draw(st.floats(1e5, 9e5)), draw(st.floats(0, 9e6))
    text = rf.to_json()
    kind = draw(st.sampled_from(["wellformed", "value", "value", "value", "deep", "bigint", "text", "bytes",
                                 "mutated"]))
    if kind == "wellformed":
        return text.encode(), rf
    if kind == "value":
        d = json.loads(text)
        keys = list(d) + ["tol.gt_g", "tol.bt_nT", "tol.dip_deg", "tol.x"]
        return json.dumps(_replace_value(draw, d, keys)).encode(), None
    if kind == "deep":
        return _deep(draw, text).encode(), None
    if kind == "bigint":
        return _bigint(draw, text).encode(), None
    if kind == "text":
        return draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"), None
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    return mutate_text(draw, text), None


@SETTINGS
@given(case=reference_files())
def test_reference_file_reader(work, case):
    from inclino.survey.geomag import ReferenceField

    data, rf = case
    got = check("reference file", ReferenceField.load, _file(work, data, ".json"), 2, rf is not None)
    if rf is not None:
        assert got.declination_deg == rf.declination_deg and got.field_nT == rf.field_nT
        assert got.grid_epsg == rf.grid_epsg and got.date == rf.date


# ------------------------------------------------------------ the tool model
@st.composite
def tool_models(draw):
    from inclino.survey import errormodel as em

    # a term of 0 is no term (not written); a model needs one term at least (a file of none is refused):
    # ABZ is above 0
    tm = em.ToolModel(name=draw(st.sampled_from(["INCLINO", "P1"])),
                      systematic={g: draw(st.floats(1e-9 if g == "ABZ" else 0, 1e-2)) for g in em.GROUPS},
                      noise={g: draw(st.floats(0, 1e-2)) for g in em.NOISE_GROUPS},
                      fit={"dip_deg": draw(st.floats(-80, 80)), "field_nT": draw(st.floats(20000, 70000))},
                      source={"calibration": "joint"})
    d = tm.iscwsa("none")
    d["inclino"] = json.loads(tm.to_json())
    text = json.dumps(d)
    kind = draw(st.sampled_from(["wellformed", "value", "value", "inclino", "inclino", "term", "deep", "bigint",
                                 "text", "bytes"]))
    if kind == "wellformed":
        return text.encode(), tm
    if kind in ("value", "inclino", "term"):
        if kind == "value":
            d = _replace_value(draw, d, ["metadata", "terms", "parameters", "inclino", "terms.0"])
        elif kind == "inclino":
            ib = d["inclino"]
            keys = ["name", "systematic", "noise", "fit", "source", "revision"] + \
                [f"systematic.{g}" for g in em.GROUPS] + [f"noise.{g}" for g in em.NOISE_GROUPS] + \
                ["fit.dip_deg", "fit.field_nT", "systematic.X"]
            d["inclino"] = _replace_value(draw, ib, keys)
        else:
            t = d["terms"][draw(st.integers(0, len(d["terms"]) - 1))]
            _replace_value(draw, t, ["name", "value", "units", "propagation_mode", "depth_formula",
                                     "inclination_formula", "azimuth_formula"])
        return json.dumps(d).encode(), None
    if kind == "deep":
        return _deep(draw, text).encode(), None
    if kind == "bigint":
        return _bigint(draw, text).encode(), None
    if kind == "text":
        return draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"), None
    return draw(st.binary(max_size=400)), None


@SETTINGS
@given(case=tool_models())
def test_tool_model_reader(work, case):
    from inclino.survey import models

    data, tm = case
    got = check("tool model", models.load_toolmodel, _file(work, data, ".json"), 2, tm is not None)
    if tm is not None:
        assert got.systematic == tm.systematic and got.noise == tm.noise


# ------------------------------------------------------------ scenarios
def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, float):
        return "inf" if v == math.inf else "-inf" if v == -math.inf else "nan" if v != v else repr(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if v is None:
        return '""'
    return str(v)


def _toml(d: dict) -> str:
    top = [f"{k} = {_toml_value(v)}" for k, v in d.items() if not isinstance(v, dict)]
    out = top
    for k, v in d.items():
        if isinstance(v, dict):
            plain = [f"{k2} = {_toml_value(v2)}" for k2, v2 in v.items() if not isinstance(v2, dict)]
            if plain:
                out += [f"[{k}]"] + plain
            for k2, v2 in v.items():
                if isinstance(v2, dict):
                    out.append(f"[{k}.{k2}]")
                    out += [f"{k3} = {_toml_value(v3)}" for k3, v3 in v2.items()]
    return "\n".join(out) + "\n"


@st.composite
def scenarios(draw):
    v3 = lambda lo, hi: [draw(st.floats(lo, hi)) for _ in range(3)]  # noqa: E731
    d = {"name": "gen", "seed": draw(st.integers(0, 2**32)), "serial": draw(st.integers(0, 2**32 - 1)),
         "world": {"field_nT": draw(st.floats(20000, 70000)), "dip_deg": draw(st.floats(-89, 89)),
                   "declination_deg": draw(st.floats(-30, 30))},
         "acc": {"bias": {"value": v3(-0.01, 0.01)}, "scale": {"value": v3(0.95, 1.05)},
                 "noise": {"sigma": v3(0, 1e-3)}},
         "mag": {"bias": {"value": v3(-500, 500)}, "hard_iron": {"value": v3(-500, 500)},
                 "noise": {"sigma": v3(0, 20)}}}
    kind = draw(st.sampled_from(["wellformed", "value", "value", "value", "text", "bytes", "mutated", "deep"]))
    if kind == "wellformed":
        return _toml(d).encode(), d
    if kind == "value":
        where = draw(st.sampled_from(["top", "world", "acc", "mag"]))
        val = draw(HOSTILE_VALUES.filter(lambda x: not (isinstance(x, dict) and not x))
                   | st.sampled_from([math.inf, -math.inf, math.nan, 0.0, 2**32, 2**64, -5.0]))
        if where == "top":
            d[draw(st.sampled_from(["seed", "serial", "name", "extra"]))] = val
        elif where == "world":
            d["world"][draw(st.sampled_from(["field_nT", "dip_deg", "declination_deg", "gravity_g", "x"]))] = val
        else:
            eff = draw(st.sampled_from(sorted(d[where])))
            key = next(iter(d[where][eff]))
            if draw(st.booleans()) and isinstance(d[where][eff][key], list):
                d[where][eff][key][draw(st.integers(0, 2))] = val
            else:
                d[where][eff][key] = val
        try:
            return _toml(d).encode(), None
        except (TypeError, ValueError):
            return b"name = 1\n", None
    if kind == "text":
        return draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"), None
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    if kind == "deep":
        return (_toml(d) + "x = " + "[" * draw(st.integers(20, 50000)) + "\n").encode(), None
    return mutate_text(draw, _toml(d)), None


@SETTINGS
@given(case=scenarios())
def test_scenario_reader(work, case):
    from inclino.model.scenario import load_scenario

    data, d = case
    s = check("scenario", load_scenario, _file(work, data, ".toml"), 2, d is not None)
    if d is not None:
        assert s.serial == d["serial"] and s.seed == d["seed"]


# ------------------------------------------------------------ CAL.json version 2
@st.composite
def calfiles_v2(draw):
    from inclino.formats import caltemp
    from inclino.formats.calfile import Calibration

    order = draw(st.integers(1, 2))
    tri = lambda lim: [[draw(st.floats(-lim, lim)) for _ in range(3)] for _ in range(order)]  # noqa: E731
    block = {"t_ref_c": draw(st.floats(0, 50)), "order": order, "span_c": [-5.0, 55.0],
             "acc": {"bias": tri(5e-5), "scale_ppm": tri(50)}, "mag": {"bias": tri(5.0), "scale_ppm": tri(50)},
             "applied_by_firmware": False}
    block.update(caltemp.firmware_block(block))
    cal = Calibration(method="joint", probe_serial=str(draw(st.integers(0, 2**32 - 1))), temperature=block)
    text = cal.to_json()
    kind = draw(st.sampled_from(["wellformed", "temp", "temp", "fixed", "fixed", "deep", "mutated", "bytes"]))
    if kind == "wellformed":
        return text.encode(), cal
    d = json.loads(text)
    if kind == "temp":
        keys = ["order", "t_ref_c", "span_c", "acc", "mag", "applied_by_firmware", "sigma", "covariance",
                "firmware", "acc.bias", "acc.scale_ppm", "mag.bias", "mag.scale_ppm"]
        _replace_value(draw, d["temperature"], keys)
        if draw(st.booleans()):
            d.pop("fixed", None)
        return json.dumps(d).encode(), None
    if kind == "fixed":
        if "temp" not in d["fixed"] or draw(st.integers(0, 4)) == 0:
            d["fixed"]["temp"] = draw(HOSTILE_VALUES)
        else:
            _replace_value(draw, d["fixed"]["temp"], list(d["fixed"]["temp"]) + ["x"])
        return json.dumps(d).encode(), None
    if kind == "deep":
        return _deep(draw, text).encode(), None
    if kind == "bytes":
        return draw(st.binary(max_size=400)), None
    return mutate_text(draw, text.replace(", ", ",")), None


@SETTINGS
@given(case=calfiles_v2())
def test_calfile_v2_reader(work, case):
    from inclino.formats.calfile import Calibration

    data, cal = case

    def read(path):
        c = Calibration.load(path)
        c.to_fixed()  # the image (version 2 when the firmware applies the terms) is built from what was read
        return c
    got = check("CAL.json version 2", read, _file(work, data, ".json"), 3, cal is not None)
    if cal is not None:
        assert got.to_fixed() == cal.to_fixed() and got.temperature["order"] == cal.temperature["order"]


def test_las_reader_names_no_parser_internals(work):
    """The draw the full profile found: a file of '~' alone made lasio's
    parser fail with 'string index out of range'; the refusal says the file
    is not LAS without it."""
    from inclino.survey import wellpath as wp

    for data in (b"~", b"~\n", b"~V\n~A\n"):
        check("survey listing (las)", wp.read_survey, _file(work, data, ".las"), 2, False)
