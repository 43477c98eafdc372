"""One input rule per format: every reader checks structure, types and
ranges before use, and every defect is one line with the documented exit
status (2 bad input; 3 a calibration refused), never a traceback, never a
Python exception's own text ("could not convert string to float", "not
NoneType"), never a library warning on stderr.

Named regressions of the hostile-input report, second round: CAL.json
(image version 1 and 2: the temperature block and its fixed-point image,
the fit report's covariance), the survey listing (CSV, JSON, LAS), the
reference file, the tool model, the noise file, the scenario, and the
out-of-range values the survey commands took."""
import json
import math
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from inclino import cli
from inclino.formats import caltemp
from inclino.formats.calfile import Calibration
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)
PY_INTERNALS = re.compile(r"could not convert|NoneType|invalid literal|object has no attribute|unhashable|"
                          r"not subscriptable|Expecting value|codec can't|Traceback|Error\b|dtype|shape \(")


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def one_line(err, *needles):
    assert err.startswith("inclino: error: ") and err.count("\n") == 1, err
    assert not PY_INTERNALS.search(err), err
    for n in needles:
        assert n in err, err


# ------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """A joint calibration with its covariance (toolmodel and trajectory
    --uncertainty read it)."""
    from inclino.calib import fit, runs
    from inclino.model.scenario import generate_raw, load_scenario

    s = load_scenario("typical")
    ds = generate_raw(s, *runs.multi_position(), seed=int(RNG.integers(1 << 30)))
    ds.meta.update(field_nT=50000.0, dip_deg=60.0)
    cal, _ = fit(ds, "joint")
    d = tmp_path_factory.mktemp("fitted")
    p = d / "cal.json"
    cal.save(str(p))
    return json.loads(p.read_text())


def temperature_block(order=1):
    """Temperature terms written by hand (values chosen here, not fitted):
    a version 2 calibration's block as CAL.json holds it."""
    block = {"t_ref_c": 25.0, "order": order, "span_c": [-5.0, 55.0],
             "acc": {"bias": [[2e-5, -1e-5, 3e-5]] * order, "scale_ppm": [[30.0, -20.0, 25.0]] * order},
             "mag": {"bias": [[2.0, -1.5, 3.0]] * order, "scale_ppm": [[50.0, 40.0, -30.0]] * order},
             "applied_by_firmware": False}
    block.update(caltemp.firmware_block(block))
    return block


@pytest.fixture
def v2(tmp_path):
    cal = Calibration(method="joint", probe_serial="1001", temperature=temperature_block())
    text = cal.to_json()
    assert "temp" in json.loads(text)["fixed"]  # image version 2
    p = tmp_path / "v2.json"
    p.write_text(text)
    return p, json.loads(text)


def _write(tmp_path, name, obj):
    p = tmp_path / name
    p.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return p


def listing(tmp_path, name="s.csv", n=12, text=None, bom=False):
    p = tmp_path / name
    if text is None:
        md = np.arange(n) * 30.0
        text = "md_m,inc_deg,azi_deg\n" + "".join(f"{m:.1f},{min(i * 3.0, 90):.2f},120.0\n"
                                                  for i, m in enumerate(md))
    p.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return p


# ------------------------------------------------------------ CAL.json: the temperature block and its image
def _cal_commands(tmp_path, cal):
    run_csv = tmp_path / "run.csv"
    run_csv.write_text("t_s,temp_c,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n"
                       + "".join(f"{i},{20 + i},0,0,1,20000,0,40000\n" for i in range(20)))
    s = listing(tmp_path)
    return {
        "attitude": ["attitude", run_csv, "--cal", cal, "-o", tmp_path / "att.csv"],
        "verify": ["verify", "--port", tmp_path / "no-port", "--cal", cal],
        "download": ["download", "--port", tmp_path / "no-port", "--cal", cal],
        "toolmodel": ["toolmodel", "--cal", cal, "--dip", "60", "--field", "50000", "-o", tmp_path / "tm.json"],
        "trajectory": ["trajectory", s, "--declination", "2", "--uncertainty", "--cal", cal, "-o",
                       tmp_path / "t.csv"],
        "compare": ["compare", s, s, "--cal", cal, "--dip", "60", "--field", "50000"],
        "diagnose --cal": ["diagnose", run_csv, "--cal", cal],
        "plot": ["plot", "--run", run_csv, "--cal", cal, "-o", tmp_path / "figs"],
        "accept": ["accept", "--port", tmp_path / "no-port", "--cal", cal],
    }


@pytest.mark.parametrize("temp", ["x", [1, 2], 7, None, {"t_ref": "a"}, {"order": 1}])
@pytest.mark.parametrize("command", ["attitude", "verify", "download", "toolmodel", "trajectory", "compare",
                                     "diagnose --cal", "plot", "accept"])
def test_mangled_fixed_temperature_image_is_exit_3_everywhere(tmp_path, capsys, v2, temp, command):
    p, d = v2
    d["fixed"]["temp"] = temp
    p.write_text(json.dumps(d))
    rc, out, err = run(capsys, *_cal_commands(tmp_path, p)[command])
    assert rc == 3, err
    one_line(err, str(p))


@pytest.mark.parametrize("field,value", [("order", "x"), ("order", 7), ("t_ref_c", "warm"), ("t_ref_c", 1e9),
                                         ("acc", "x"), ("acc", {"bias": "x", "scale_ppm": [[1, 2, 3]]}),
                                         ("mag", {"bias": [[1, 2]], "scale_ppm": [[1, 2, 3]]}),
                                         ("applied_by_firmware", "yes"), ("span_c", [1])])
def test_mangled_temperature_block_is_exit_3(tmp_path, capsys, v2, field, value):
    p, d = v2
    d["temperature"][field] = value
    d.pop("fixed")  # the image is derived from the block: the block's own rules are what is checked
    p.write_text(json.dumps(d))
    for command in ("attitude", "diagnose --cal", "download"):
        rc, out, err = run(capsys, *_cal_commands(tmp_path, p)[command])
        assert rc == 3, (command, err)
        one_line(err, str(p), "temperature")


def test_huge_temperature_term_without_a_warning(tmp_path, capsys, v2):
    """A term beyond every range: refused (exit 3) without numpy's overflow warning."""
    p, d = v2
    d["temperature"]["acc"]["bias"] = [[1e300, 0, 0]]
    d["temperature"]["applied_by_firmware"] = True
    d.pop("fixed")
    p.write_text(json.dumps(d))
    r = subprocess.run([sys.executable, "-m", "inclino", "download", "--port", str(tmp_path / "no-port"), "--cal", str(p)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 3, r.stderr
    one_line(r.stderr)
    assert "Warning" not in r.stderr


@pytest.mark.parametrize("case", ["string", "ragged", "zero", "negative", "nan-sigma", "string-sigma"])
@pytest.mark.parametrize("command", ["toolmodel", "trajectory"])
def test_mangled_covariance_is_exit_3(tmp_path, capsys, fitted, case, command):
    d = json.loads(json.dumps(fitted))
    unc = d["report"]["uncertainty"]
    if case == "string":
        unc["covariance"] = "big"
    elif case == "ragged":
        unc["covariance"] = [[1.0] * 24] * 23 + [[1.0] * 5]
    elif case == "zero":
        unc["covariance"] = [[0.0] * 24 for _ in range(24)]
        unc.pop("sigma", None)
    elif case == "negative":
        unc["covariance"] = (-np.eye(24)).tolist()
        unc.pop("sigma", None)
    else:
        unc.pop("covariance", None)
        unc["sigma"] = {k: ("x" if case == "string-sigma" else -1.0) for k in unc["sigma"]}
    cal = _write(tmp_path, "cal.json", d)
    rc, out, err = run(capsys, *_cal_commands(tmp_path, cal)[command])
    assert rc == 3, err
    one_line(err, "covariance" if case in ("string", "ragged", "zero", "negative") else "sigma")
    assert not (tmp_path / "tm.json").exists() and not (tmp_path / "t.csv").exists()


def test_toolmodel_never_writes_nan(tmp_path, capsys, fitted):
    """Every number of the tool model is finite JSON (no NaN, no null for a number)."""
    cal = _write(tmp_path, "cal.json", fitted)
    rc, out, err = run(capsys, "toolmodel", "--cal", cal, "--dip", "60", "--field", "50000", "-o", tmp_path / "tm.json")
    assert rc in (0, 1), err
    text = (tmp_path / "tm.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the tool model"))


# ------------------------------------------------------------ the survey-side readers
DEEP = "[" * 100000 + "]" * 100000


@pytest.mark.parametrize("reader", ["listing", "ref", "tool-model", "noise"])
@pytest.mark.parametrize("content", ["deep", "bigint"])
def test_hostile_json_in_every_survey_reader(tmp_path, capsys, fitted, reader, content):
    text = DEEP if content == "deep" else '{"md_m": ' + "9" * 5000 + ', "inc_deg": 1, "azi_deg": 2}'
    bad = _write(tmp_path, "bad.json", text)
    s = listing(tmp_path)
    cal = _write(tmp_path, "cal.json", fitted)
    argv = {"listing": ["trajectory", bad, "--declination", "2", "-o", tmp_path / "t.csv"],
            "ref": ["trajectory", s, "--ref", bad, "-o", tmp_path / "t.csv"],
            "tool-model": ["trajectory", s, "--declination", "2", "--uncertainty", "--tool-model", bad, "-o",
                           tmp_path / "t.csv"],
            "noise": ["toolmodel", "--cal", cal, "--dip", "60", "--field", "50000", "--noise", bad, "-o",
                      tmp_path / "tm.json"]}[reader]
    rc, out, err = run(capsys, *argv)
    assert rc == 2, err
    one_line(err, str(bad))


def test_non_number_in_a_las_listing(tmp_path, capsys):
    las = tmp_path / "s.las"
    las.write_text("~Version\nVERS. 2.0 :\nWRAP. NO :\n~Well\nNULL. -999.25 :\n~Curve\nMD.m : depth\n"
                   "INC.deg : inc\nAZI.deg : azi\n~A\n0 0 0\n30 i 10\n60 5 10\n")
    rc, out, err = run(capsys, "trajectory", las, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, str(las))
    assert "Only engine" not in err


LAS_HEAD = ("~Version\nVERS. 2.0 :\nWRAP. NO :\n~Well\nNULL. -999.25 :\n~Curve\nMD.m : depth\n"
            "INC.deg : inc\nAZI.deg : azi\n~A\n0 0 0\n")


def test_decimal_comma_in_a_las_listing_is_refused_by_line(tmp_path, capsys):
    """lasio's default rewrites read "5,5" as 5.5; every other reader refuses a
    decimal comma with the place named."""
    las = tmp_path / "s.las"
    las.write_text(LAS_HEAD + "30 5,5 10\n60 5 10\n")
    rc, out, err = run(capsys, "trajectory", las, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, str(las), "INC", "data line 2")


def test_long_line_in_a_las_listing_is_read_in_linear_time(tmp_path, capsys):
    """A data line of a million digits: lasio's run-on pattern backtracks in
    time quadratic in the line's length (hours for this line; seconds here)."""
    import signal

    las = tmp_path / "s.las"
    las.write_text(LAS_HEAD + "30 5 " + "7" * 1_000_000 + "\n60 5 10\n")

    class Hung(BaseException):  # not an Exception: no reader's handler turns it into a refusal
        pass

    def stop(*_):
        raise Hung

    old = signal.signal(signal.SIGALRM, stop)
    signal.alarm(120)
    try:
        rc, out, err = run(capsys, "trajectory", las, "--declination", "2", "-o", tmp_path / "t.csv")
    except Hung:
        pytest.fail("reading a LAS line of a million digits did not end within 120 s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert rc == 2, err
    one_line(err, str(las))


@pytest.mark.parametrize("where", ["STEP", "VERS", "curve"])
def test_long_header_line_in_a_las_listing_is_refused_by_line(tmp_path, capsys, where):
    """A header item of a million characters (a value, or a curve's
    description): lasio formats each header item for its debug log in time
    quadratic in its length (25 CPU s for 1 MB), so such a line is refused
    by its number before lasio reads the file; the listing's data lines are
    not limited by it."""
    long = "7" * 1_000_000
    head = {"STEP": LAS_HEAD.replace("NULL. -999.25 :", "NULL. -999.25 :\nSTEP.M 0 :" + long),
            "VERS": LAS_HEAD.replace("VERS. 2.0 :", "VERS. 2.0 : " + long),
            "curve": LAS_HEAD.replace("AZI.deg : azi", "AZI.deg : " + long)}[where]
    lineno = head[:head.index(long)].count("\n") + 1
    las = tmp_path / "s.las"
    las.write_text(head + "30 5 10\n")
    rc, out, err = run(capsys, "trajectory", las, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, f"{las}:{lineno}:", "header line")
    assert not (tmp_path / "t.csv").exists()


def test_listing_with_a_byte_order_mark(tmp_path, capsys):
    s = listing(tmp_path, bom=True)
    rc, out, err = run(capsys, "trajectory", s, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 0, err


@pytest.mark.parametrize("reader", ["listing", "dataset", "calibration", "ref"])
def test_non_utf8_byte_names_its_line(tmp_path, capsys, reader):
    lines = ["md_m,inc_deg,azi_deg"] + [f"{i * 30},{i},{10}" for i in range(40)]
    if reader == "dataset":
        lines = ["ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT"] + ["0,0,1,20000,0,40000"] * 40000
    raw = ("\n".join(lines) + "\n").encode()
    if reader in ("calibration", "ref"):
        raw = ('{\n' + '"pad": 0,\n' * 30 + '"x": "caf\xe9"\n}\n').encode("latin-1")
        line = 32
    else:
        k = 37 if reader == "listing" else 33000
        parts = raw.split(b"\n")
        parts[k - 1] = parts[k - 1] + b"\xff"
        raw = b"\n".join(parts)
        line = k
    p = tmp_path / "bad.txt"
    p.write_bytes(raw)
    s = listing(tmp_path)
    argv = {"listing": ["trajectory", p, "--declination", "2", "-o", tmp_path / "t.csv"],
            "dataset": ["attitude", p, "-o", tmp_path / "a.csv"],
            "calibration": ["attitude", s, "--cal", p, "-o", tmp_path / "a.csv"],
            "ref": ["trajectory", s, "--ref", p, "-o", tmp_path / "t.csv"]}[reader]
    rc, out, err = run(capsys, *argv)
    assert rc in (2, 3), err
    one_line(err)
    assert re.search(rf"(:{line}\b|line {line}\b)", err), err


@pytest.mark.parametrize("field,value", [("declination_deg", "east"), ("grid_epsg", 999999), ("date", 20240101),
                                         ("gravity_g", -5), ("field_nT", 1e9), ("dip_deg", 95),
                                         ("tol", {"gt_g": "x", "bt_nT": 300, "dip_deg": 0.25}), ("lat_deg", "n")])
def test_mangled_reference_file(tmp_path, capsys, field, value):
    r = tmp_path / "r.json"
    assert cli.main(["reffield", "--declination", "3", "--dip", "60", "--field", "50000", "-o", str(r)]) == 0
    capsys.readouterr()
    d = json.loads(r.read_text())
    d[field] = value
    r.write_text(json.dumps(d))
    rc, out, err = run(capsys, "trajectory", listing(tmp_path), "--ref", r, "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, str(r), field)


@pytest.mark.parametrize("opt,value", [("--declination", "400"), ("--field", "1e9"), ("--dip", "91"),
                                       ("--gravity", "-5"), ("--field", "-3")])
def test_out_of_range_reference_options(tmp_path, capsys, opt, value):
    rc, out, err = run(capsys, "reffield", "--declination", "3", opt, value)
    assert rc == 2, err
    one_line(err, opt)


def test_reffield_at_the_pole_is_clean(tmp_path, capsys):
    """The geographic pole: north (and so the declination) is undefined
    there: refused in one line, no NumPy warning, nothing written."""
    r = subprocess.run([sys.executable, "-m", "inclino", "reffield", "--lat", "90", "--lon", "0", "--date",
                        "2024-06-01", "-o", str(tmp_path / "r.json")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    one_line(r.stderr, "pole")
    assert not (tmp_path / "r.json").exists()
    r = subprocess.run([sys.executable, "-m", "inclino", "reffield", "--lat", "89.5", "--lon", "0", "--date",
                        "2024-06-01", "--json"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    d = json.loads(r.stdout)
    assert all(isinstance(d[k], float) and math.isfinite(d[k]) for k in ("declination_deg", "dip_deg", "field_nT"))


@pytest.mark.parametrize("md", ["1e300", "-1e300", "1e9"])
def test_depth_out_of_range_in_a_listing(tmp_path, capsys, md):
    s = listing(tmp_path, text=f"md_m,inc_deg,azi_deg\n0,0,0\n{md},5,10\n")
    rc, out, err = run(capsys, "trajectory", s, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, "md_m")


@pytest.mark.parametrize("field,value", [("systematic", {"ABXY-TI1S": "x"}), ("systematic", "all"),
                                         ("noise", {"ABXY-R": -1}), ("fit", 3), ("name", 7)])
def test_mangled_tool_model(tmp_path, capsys, fitted, field, value):
    cal = _write(tmp_path, "cal.json", fitted)
    assert cli.main(["toolmodel", "--cal", str(cal), "--dip", "60", "--field", "50000", "-o", str(tmp_path / "tm.json")]) \
        in (0, 1)
    capsys.readouterr()
    d = json.loads((tmp_path / "tm.json").read_text())
    if isinstance(value, dict):
        d["inclino"][field].update(value)
    else:
        d["inclino"][field] = value
    tm = _write(tmp_path, "tm2.json", d)
    rc, out, err = run(capsys, "trajectory", listing(tmp_path), "--declination", "2", "--uncertainty",
                       "--tool-model", tm, "-o", tmp_path / "t.csv")
    assert rc == 2, err
    one_line(err, str(tm))


# ------------------------------------------------------------ scenario files
SCENARIO = """name = "hostile"
seed = 5
serial = {serial}
[world]
field_nT = 50000.0
dip_deg = 60.0
[acc.noise]
sigma = {sigma}
[acc.scale]
value = {scale}
"""


@pytest.mark.parametrize("field,bad", [("sigma", "inf"), ("sigma", "nan"), ("scale", "[0.0, 1.0, 1.0]"),
                                       ("serial", str(2**32 + 7)), ("serial", "-1"), ("sigma", "'loud'")])
def test_hostile_scenario_is_refused(tmp_path, capsys, field, bad):
    vals = {"serial": "1001", "sigma": "1e-4", "scale": "[1.0, 1.0, 1.0]"}
    vals[field] = bad
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.format(**vals))
    from inclino.errors import DataError
    from inclino.model.scenario import load_scenario

    with pytest.raises(DataError) as e:
        load_scenario(str(p))
    assert str(p) in str(e.value) and not PY_INTERNALS.search(str(e.value))
    # the command refuses it in one line before it starts (a refused scenario never runs the emulator)
    r = subprocess.run([sys.executable, "-m", "inclino", "emulate", "--scenario", str(p)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2
    one_line(r.stderr, str(p))


def test_good_scenario_file_loads(tmp_path):
    from inclino.model.scenario import load_scenario

    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.format(serial=str(2**32 - 1), sigma="1e-4", scale="[1.0, 1.01, 0.99]"))
    s = load_scenario(str(p))
    assert s.serial == 2**32 - 1


# ------------------------------------------------------------ messages
def test_diagnose_cal_corrupt_is_exit_3(tmp_path, capsys):
    run_csv = tmp_path / "run.csv"
    run_csv.write_text("t_s,temp_c,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n"
                       + "".join(f"{i},{20 + i},0,0,1,20000,0,40000\n" for i in range(20)))
    cal = _write(tmp_path, "cal.json", '{"format": 1, "acc_m": "x"}')
    rc, out, err = run(capsys, "diagnose", run_csv, "--cal", cal)
    assert rc == 3, err
    one_line(err, str(cal))


@pytest.mark.parametrize("argv,needle", [(["trajectory", "x.csv", "-o", "t.csv", "--k"], "--k"),
                                         (["calibrate", "r.csv", "--method", "magic", "-o", "c.json"], "--method"),
                                         (["frobnicate"], "frobnicate"), (["identify", "--port", "x", "--bogus"], "--bogus")])
def test_option_errors_are_one_line(capsys, argv, needle):
    rc, out, err = run(capsys, *argv)
    assert rc == 2 and out == ""
    assert err.startswith("inclino: error: ") and err.count("\n") == 1 and "usage:" not in err, err
    assert needle in err


def test_survey_listing_errors_carry_no_python_internals(tmp_path, capsys):
    s = listing(tmp_path, text="md_m,inc_deg,azi_deg\n0,0,0\n30,i,10\n")
    rc, out, err = run(capsys, "trajectory", s, "--declination", "2", "-o", tmp_path / "t.csv")
    assert rc == 2
    one_line(err, "inc_deg", "'i'")
    n = _write(tmp_path, "n.json", '[{"gt_g": null, "bt_nT": 50000}]')
    cal = tmp_path / "c.json"
    Calibration().save(str(cal))
    rc, out, err = run(capsys, "toolmodel", "--cal", cal, "--noise", n, "--dip", "60", "--field", "50000", "-o",
                       tmp_path / "tm.json")
    assert rc in (2, 3)
    one_line(err)


@pytest.mark.parametrize("cell", ["\uff11.5", "\u0661.5", "0.\u0665"])
def test_digits_other_than_ascii_are_no_number(tmp_path, capsys, cell):
    """Python's float() reads fullwidth and Arabic-Indic digits ("１.5" as
    1.5); a dataset's numbers are plain ASCII decimals (docs/dataset.md)."""
    p = tmp_path / "d.csv"
    p.write_text(f"ax_g,ay_g,az_g\n0,0,1\n0,{cell},1\n", encoding="utf-8")
    rc = cli.main(["attitude", str(p), "-o", str(tmp_path / "a.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and f"{p}:3: column ay_g: {cell!r} is not a number" in err and err.count("\n") == 1, err
    p.write_text(f"# field_nT={cell}\nax_g,ay_g,az_g\n0,0,1\n", encoding="utf-8")
    assert cli.main(["attitude", str(p), "-o", str(tmp_path / "a.csv")]) == 2
    assert "is not a plain number" in capsys.readouterr().err


def test_a_header_key_given_twice_is_refused(tmp_path, capsys):
    """`# field_nT=48000` then `# field_nT=30000`: the second was used without
    a word (a column named twice is refused: which copy was meant is unknown)."""
    p = tmp_path / "d.csv"
    p.write_text("# field_nT=48000\n# field_nT=30000\nax_g,ay_g,az_g\n0,0,1\n")
    rc = cli.main(["attitude", str(p), "-o", str(tmp_path / "a.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and f"{p}:2: header key field_nT given twice (48000.0 and 30000)" in err, err
