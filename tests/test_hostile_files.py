"""Hostile files and paths given to the commands that read datasets and
calibration files and write outputs: every case is one error line on stderr
and a documented exit status, nothing is written on a refusal, and an
output never replaces an input, a device or a symbolic link.

Named regressions for the file-and-option half of the hostile-input report
(docs/cli.md "Output files", docs/dataset.md)."""
import json
import math
import os
import stat
import subprocess
import sys

import numpy as np
import pytest

from inclino import calib, cli
from inclino.errors import DataError
from inclino.formats import dataset, safeio
from inclino.engines import reference
from inclino.formats.calfile import Calibration
from inclino.benchmarks import calibration as bench
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)

HEADER = "t_s,inc_deg,azi_deg,tf_deg,temp_c,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT"


def _one_error(err: str, needle: str = "") -> None:
    assert err.count("\n") == 1 and err.startswith("inclino: error: "), err
    assert "Traceback" not in err and needle in err, err


def _rows(n=40, seed=None, field=52000.0, dip=45.1):
    """n random poses, exact body vectors (independent of the reader)."""
    rng = np.random.default_rng(seed)
    inc, azi, tf = rng.uniform(2, 178, n), rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    g, b = reference.body_vectors(inc, azi, tf, field, dip)
    return inc, azi, tf, g, b


def _csv_text(inc, azi, tf, g, b, meta="# field_nT=52000\n# dip_deg=45.1\n"):
    lines = [HEADER]
    for i in range(len(inc)):
        lines.append(",".join(repr(float(v)) for v in (i, inc[i], azi[i], tf[i], 25.0, *g[i], *b[i])))
    return meta + "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def run_csv(tmp_path_factory):
    """A calibration run every method can fit (the bench's poses)."""
    d = tmp_path_factory.mktemp("hostile")
    s = bench.bench_probe(linear=True)
    ds = bench.emulated_run(s, bench.calibration_poses(), seed=5)
    p = d / "run.csv"
    dataset.write_raw(str(p), ds)
    return p


# ------------------------------------------------------------ 3: rows read by position
@pytest.mark.parametrize("command", ["attitude", "diagnose", "calibrate"])
def test_decimal_comma_row_is_an_error_naming_the_row(tmp_path, capsys, command):
    inc, azi, tf, g, b = _rows(60)
    text = _csv_text(inc, azi, tf, g, b).splitlines()
    bad = 3 + RNG.integers(5, 50)  # a random data line (meta 2 + header 1)
    cells = text[bad - 1].split(",")
    k = RNG.integers(5, 11)
    cells[k] = cells[k].replace(".", ",", 1) if "." in cells[k] else cells[k] + ",5"
    text[bad - 1] = ",".join(cells)
    p = tmp_path / "comma.csv"
    p.write_text("\n".join(text) + "\n")
    argv = {"attitude": ["attitude", str(p), "-o", str(tmp_path / "o.csv")],
            "diagnose": ["diagnose", str(p)],
            "calibrate": ["calibrate", str(p), "-o", str(tmp_path / "c.json")]}[command]
    assert cli.main(argv) == 2
    _one_error(capsys.readouterr().err, f"comma.csv:{bad}: 12 cells, the header has 11 (a decimal comma?")
    assert not (tmp_path / "o.csv").exists() and not (tmp_path / "c.json").exists()


def test_row_with_two_extra_cells_or_one_missing_names_the_row(tmp_path, capsys):
    inc, azi, tf, g, b = _rows(10)
    lines = _csv_text(inc, azi, tf, g, b, meta="").splitlines()
    lines[4] += ",1,2"
    (tmp_path / "extra.csv").write_text("\n".join(lines) + "\n")
    assert cli.main(["attitude", str(tmp_path / "extra.csv"), "-o", "-"]) == 2
    _one_error(capsys.readouterr().err, "extra.csv:5: 13 cells, the header has 11")
    lines = _csv_text(inc, azi, tf, g, b, meta="").splitlines()
    lines[7] = lines[7].rsplit(",", 1)[0]
    (tmp_path / "short.csv").write_text("\n".join(lines) + "\n")
    assert cli.main(["attitude", str(tmp_path / "short.csv"), "-o", "-"]) == 2
    _one_error(capsys.readouterr().err, "short.csv:8: 10 cells, the header has 11")


def test_underscore_digits_are_not_a_number(tmp_path, capsys):
    inc, azi, tf, g, b = _rows(5)
    text = _csv_text(inc, azi, tf, g, b, meta="").replace("25.0", "2_5.0", 1)
    (tmp_path / "u.csv").write_text(text)
    assert cli.main(["attitude", str(tmp_path / "u.csv"), "-o", "-"]) == 2
    _one_error(capsys.readouterr().err, "u.csv:2: column temp_c: '2_5.0' is not a number")


# ------------------------------------------------------------ 4: outputs never replace inputs
def _links(tmp_path, src):
    hard = tmp_path / "hard.csv"
    os.link(src, hard)
    soft = tmp_path / "soft.csv"
    soft.symlink_to(src)
    return [src, hard, soft]


def test_attitude_output_that_is_the_input_is_refused(tmp_path, capsys):
    inc, azi, tf, g, b = _rows(20)
    src = tmp_path / "r.csv"
    src.write_text(_csv_text(inc, azi, tf, g, b))
    before = src.read_bytes()
    for out in _links(tmp_path, src):
        assert cli.main(["attitude", str(src), "-o", str(out)]) == 2
        _one_error(capsys.readouterr().err, "it is the input file")
    assert src.read_bytes() == before and (tmp_path / "soft.csv").is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hard.csv", "r.csv", "soft.csv"]  # no temporary left


def test_calibrate_output_that_is_the_input_is_refused(run_csv, tmp_path, capsys):
    src = tmp_path / "r.csv"
    src.write_bytes(run_csv.read_bytes())
    for out in _links(tmp_path, src):
        assert cli.main(["calibrate", str(src), "-o", str(out)]) == 2
        _one_error(capsys.readouterr().err, "it is the input file")
    assert src.read_bytes() == run_csv.read_bytes()
    # the prior calibration is an input too
    cal = tmp_path / "prior.json"
    Calibration().save(str(cal))
    assert cli.main(["calibrate", str(src), "--prior", str(cal), "-o", str(cal)]) == 2
    _one_error(capsys.readouterr().err, "it is the input file")


@pytest.mark.parametrize("command", ["attitude", "calfile"])
def test_output_through_a_symlink_is_written_through_and_keeps_the_mode(run_csv, tmp_path, capsys, command):
    target = tmp_path / "real" / "out"
    target.parent.mkdir()
    target.write_text("old\n")
    mode = int(RNG.choice([0o600, 0o640, 0o644, 0o664]))
    os.chmod(target, mode)
    link = tmp_path / "out"
    link.symlink_to(target)
    if command == "attitude":
        assert cli.main(["attitude", str(run_csv), "-o", str(link)]) == 0
        assert target.read_text().startswith("inc_deg,")
    else:  # what calibrate -o does with its result
        Calibration(method="joint").save(str(link), inputs=[str(run_csv)])
        assert Calibration.load(str(target)).method == "joint"
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert stat.S_IMODE(os.stat(target).st_mode) == mode
    assert sorted(p.name for p in target.parent.iterdir()) == ["out"]


def test_calfile_is_readable_like_any_output(run_csv, tmp_path, capsys):
    umask = int(RNG.choice([0o022, 0o002, 0o027]))
    old = os.umask(umask)
    try:
        out = tmp_path / "new.json"
        Calibration(method="joint").save(str(out))  # what calibrate -o does with its result
        att = tmp_path / "att.csv"
        assert cli.main(["attitude", str(run_csv), "-o", str(att)]) == 0
    finally:
        os.umask(old)
    capsys.readouterr()
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o666 & ~umask == stat.S_IMODE(os.stat(att).st_mode)


def test_device_outputs_are_written_into_never_replaced(run_csv, tmp_path, capsys):
    for dev in ("/dev/null", "/dev/full"):
        if not os.path.exists(dev):
            pytest.skip(f"{dev} missing on this system")
    assert cli.main(["attitude", str(run_csv), "-o", "/dev/null"]) == 0
    assert cli.main(["attitude", str(run_csv), "-o", "/dev/full"]) == 2
    _one_error(capsys.readouterr().err, "cannot write /dev/full: No space left on device")
    with pytest.raises(Exception, match="cannot write /dev/full: No space left on device") as e:
        Calibration().save("/dev/full")  # what calibrate -o does with its result
    assert e.value.exit_code == 2
    for dev in ("/dev/null", "/dev/full"):
        assert stat.S_ISCHR(os.stat(dev).st_mode)


def test_directory_output_refused(run_csv, tmp_path, capsys):
    assert cli.main(["attitude", str(run_csv), "-o", str(tmp_path)]) == 2
    _one_error(capsys.readouterr().err, "it is a directory")


def test_failed_write_leaves_the_target_and_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "out.csv"
    target.write_text("precious\n")

    def full(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(Exception) as e:
        safeio.write_output(str(target), "new content\n")
    assert "No space left on device" in str(e.value) and e.value.exit_code == 2
    assert target.read_text() == "precious\n" and [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_dangling_symlink_creates_its_target(tmp_path):
    link = tmp_path / "l.json"
    link.symlink_to(tmp_path / "t.json")
    safeio.write_output(str(link), "{}\n")
    assert link.is_symlink() and (tmp_path / "t.json").read_text() == "{}\n"


# ------------------------------------------------------------ 6: one line, never a traceback
def _cal_variants(tmp_path, good: Calibration):
    d = json.loads(good.to_json())
    text = json.dumps(d)
    first = json.dumps(d["fixed"]["acc_m"][0])
    rng = RNG
    v = {
        "binary": os.urandom(64) + b"\x00" + os.urandom(64),
        "latin1": text.replace('"method": "', '"method": "\xe9', 1).encode("latin-1"),
        "digits400": text.replace(first, "1" + "".join(str(x) for x in rng.integers(0, 10, 399)), 1).encode(),
        "inf_fixed": text.replace(first, "1e999", 1).encode(),
        "inf_float": text.replace(json.dumps(d["acc_m"][0][0]), "-1e999", 1).encode(),
        "nan": text.replace(json.dumps(d["mag_b"][0]), "NaN", 1).encode(),
        "deep": b"[" * int(rng.integers(1000, 60000)),
        "deep_report": text.replace('"report": {', '"report": {"x": ' + "[" * 200 + "]" * 200 + ", ", 1).encode()
        if '"report": {' in text else (text[:-1] + ', "report": ' + "[" * 200 + "]" * 200 + "}").encode(),
        "ragged": text.replace(json.dumps(d["acc_m"][0]), "[0.0, 0.0]", 1).encode(),  # found by the property suite
        "huge": b'{"format": 1, "x": "' + b"a" * (safeio.MAX_JSON_BYTES + 10) + b'"}',
    }
    out = {}
    for k, data in v.items():
        p = tmp_path / f"{k}.json"
        p.write_bytes(data)
        out[k] = p
    return out


@pytest.mark.parametrize("command", ["attitude", "download", "verify", "accept"])
def test_hostile_calfile_is_one_line_for_every_command(tmp_path, capsys, command):
    inc, azi, tf, g, b = _rows(5)
    src = tmp_path / "r.csv"
    src.write_text(_csv_text(inc, azi, tf, g, b))
    good = Calibration(acc_b=[0.01, 0.0, 0.0], method="joint", probe_serial="1")
    port = str(tmp_path / "no-such-port")  # the file must be refused before the port is opened
    for name, p in _cal_variants(tmp_path, good).items():
        argv = {"attitude": ["attitude", str(src), "--cal", str(p), "-o", str(tmp_path / "o.csv")],
                "download": ["download", "--port", port, "--cal", str(p)],
                "verify": ["verify", "--port", port, "--cal", str(p)],
                "accept": ["accept", "--port", port, "--cal", str(p)]}[command]
        rc = cli.main(argv)
        err = capsys.readouterr().err
        assert rc == 3, (name, err)
        _one_error(err, p.name)
    assert not (tmp_path / "o.csv").exists()


def test_calfile_with_bom_and_integral_floats_loads(tmp_path):
    good = Calibration(mag_b=[100.0, -20.5, 3.0], method="joint")
    d = json.loads(good.to_json())
    d["fixed"]["acc_m"] = [float(v) for v in d["fixed"]["acc_m"]]
    p = tmp_path / "bom.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps(d).encode())
    assert Calibration.load(str(p)).to_fixed() == good.to_fixed()


def test_attitude_dev_full_is_one_line_in_a_process(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("/dev/full missing on this system")
    inc, azi, tf, g, b = _rows(3000)
    src = tmp_path / "r.csv"
    src.write_text(_csv_text(inc, azi, tf, g, b))
    r = subprocess.run([sys.executable, "-m", "inclino", "attitude", str(src), "-o", "/dev/full"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    _one_error(r.stderr, "No space left on device")


MEMLIMIT = """
import resource, sys
from inclino.cli import main
import inclino.diagnose.analysis, inclino.diagnose.core, inclino.formats.dataset, scipy.optimize, scipy.stats  # noqa
with open("/proc/self/statm") as f:
    vsz = int(f.read().split()[0]) * resource.getpagesize()
lim = vsz + 10 * 2**20  # 10 MiB more than the interpreter and its libraries hold now
resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
sys.exit(main(["diagnose", sys.argv[1]]))
"""


def test_diagnose_large_file_under_memory_limit_is_one_line(tmp_path):
    if not os.path.exists("/proc/self/statm"):
        pytest.skip("needs /proc (Linux)")
    inc, azi, tf, g, b = _rows(1)
    row = _csv_text(inc, azi, tf, g, b, meta="").splitlines()[1] + "\n"
    p = tmp_path / "big.csv"
    p.write_text(HEADER + "\n" + row * 200_000)  # 17 MB of values: more than the limit leaves
    r = subprocess.run([sys.executable, "-c", MEMLIMIT, str(p)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr[-2000:]
    _one_error(r.stderr, "out of memory")


# ------------------------------------------------------------ 8: file headers and poses
@pytest.mark.parametrize("meta,needle", [
    ("# field_nT=-50000\n", "header field_nT=-50000 out of range"),
    ("# field_nT=0\n", "header field_nT=0 out of range"),
    ("# dip_deg=500\n", "header dip_deg=500 out of range"),
    ("# gravity_g=-1\n", "header gravity_g=-1 out of range"),
    ("# lat_deg=91\n", "header lat_deg=91 out of range"),
])
@pytest.mark.parametrize("command", ["attitude", "calibrate", "diagnose"])
def test_header_out_of_range_is_refused(tmp_path, capsys, meta, needle, command):
    inc, azi, tf, g, b = _rows(30)
    p = tmp_path / "h.csv"
    p.write_text(_csv_text(inc, azi, tf, g, b, meta=meta))
    argv = {"attitude": ["attitude", str(p), "-o", str(tmp_path / "o")], "diagnose": ["diagnose", str(p)],
            "calibrate": ["calibrate", str(p), "-o", str(tmp_path / "o")]}[command]
    assert cli.main(argv) == 2
    _one_error(capsys.readouterr().err, f"h.csv:1: {needle}")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("twice", ["mx_nT", "az_g", "inc_deg", "note"])
@pytest.mark.parametrize("command", ["attitude", "calibrate", "diagnose"])
def test_repeated_column_name_is_refused(tmp_path, capsys, twice, command):
    """A header naming a column twice (a sensor, a pose or an ignored
    column) is refused whichever copy holds the right values: the first
    copy holds the true values here and the second a constant, so reading
    either one silently would give a plausible result."""
    inc, azi, tf, g, b = _rows(30, seed=4)
    lines = _csv_text(inc, azi, tf, g, b).splitlines()
    hdr = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    extra = [twice] if twice in HEADER.split(",") else [twice, twice]  # an ignored column: there twice
    lines[hdr] += "," + ",".join(extra)
    for i in range(hdr + 1, len(lines)):
        lines[i] += ",0.5" * len(extra)
    p = tmp_path / "twice.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=f"twice.csv:{hdr + 1}: column name repeated in the header: "
                                                f"{twice}$"):
        dataset.read_raw(str(p))
    argv = {"attitude": ["attitude", str(p), "-o", str(tmp_path / "o")], "diagnose": ["diagnose", str(p)],
            "calibrate": ["calibrate", str(p), "-o", str(tmp_path / "o")]}[command]
    assert cli.main(argv) == 2
    _one_error(capsys.readouterr().err, f"twice.csv:{hdr + 1}: column name repeated in the header: {twice}")
    assert not (tmp_path / "o").exists()
    # the same file with the second copy renamed is read: the refusal is the repeat's
    lines[hdr] = lines[hdr].rsplit(",", 1)[0] + ",spare"
    q = tmp_path / "once.csv"
    q.write_text("\n".join(lines) + "\n")
    assert len(dataset.read_raw(str(q))) == 30


@pytest.mark.parametrize("method", list(calib.METHODS))
def test_pose_inclination_500_refused_by_every_method(run_csv, tmp_path, capsys, method):
    lines = run_csv.read_text().splitlines()
    hdr = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    col = lines[hdr].split(",").index("inc_deg")
    row = hdr + 1 + int(RNG.integers(0, len(lines) - hdr - 1))
    cells = lines[row].split(",")
    cells[col] = "500"
    lines[row] = ",".join(cells)
    p = tmp_path / "pose.csv"
    p.write_text("\n".join(lines) + "\n")
    assert cli.main(["calibrate", str(p), "--method", method, "-o", str(tmp_path / "c.json")]) == 2
    _one_error(capsys.readouterr().err, f"pose.csv:{row + 1}: column inc_deg: 500 out of range")
    assert not (tmp_path / "c.json").exists()


# ------------------------------------------------------------ 11: messages
def test_utf8_bom_file_is_read(tmp_path, capsys):
    inc, azi, tf, g, b = _rows(12)
    text = _csv_text(inc, azi, tf, g, b)
    (tmp_path / "plain.csv").write_text(text)
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + text.encode())
    for bom_first_line in (text, text.split("\n", 2)[2]):  # BOM before a comment and before the header
        (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + bom_first_line.encode())
        a = dataset.read_raw(str(tmp_path / "bom.csv"))
        assert np.array_equal(a.acc, dataset.read_raw(str(tmp_path / "plain.csv")).acc)
    assert cli.main(["attitude", str(tmp_path / "bom.csv"), "-o", str(tmp_path / "o.csv")]) == 0
    assert capsys.readouterr().err == ""


def test_bootstrap_2_prints_no_numpy_warnings(run_csv, tmp_path, capsys):
    import warnings

    verdicts = {}
    for method in calib.METHODS:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rc = cli.main(["calibrate", str(run_csv), "--method", method, "--bootstrap", "2",
                           "-o", str(tmp_path / f"{method}.json")])
        assert capsys.readouterr().err == ""
        rep = json.loads((tmp_path / f"{method}.json").read_text())["report"]
        assert rc == (0 if rep["passed"] else 1), (method, rc, rep["reasons"])
        verdicts[method] = rep["passed"]
        assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], (method, caught[0].message)
    # the bench's seeded linear probe on the union of the papers' poses (emulated_run, seed 5): every
    # method's fit passes its verdict
    assert all(verdicts.values()), verdicts


# ------------------------------------------------------------ 7: long runs
def test_thinning_rule_keeps_one_row_per_stretch():
    n = int(RNG.integers(1000, 5000))
    m = int(RNG.integers(50, 400))
    ds = dataset.RawDataset({c: np.arange(n, dtype=float) + j for j, c in enumerate(dataset.SENSOR_COLS)})
    sub, note = dataset.thin(ds, m)
    kept = sub.columns["ax_g"].astype(int)
    assert len(kept) == m and np.all(np.diff(kept) > 0)
    edges = (np.arange(m + 1) * n) // m  # m stretches of the run, one row kept in each
    assert np.all((kept >= edges[:-1]) & (kept < edges[1:]))
    assert f"{m} of them were used" in note and dataset.thin(ds, n) == (ds, None)
    again, _ = dataset.thin(ds, m)  # seeded: the same file gives the same rows
    assert np.array_equal(again.columns["ax_g"], sub.columns["ax_g"])


@pytest.mark.parametrize("period", [2, 3, 120])
def test_thinning_does_not_alias_a_repeated_pattern(period):
    """A run whose rows repeat a pattern of `period` (alternating poses, a
    repeated pose table): the rows kept hold every phase of the pattern in
    its share.  A stride of k = ceil(n / m) kept only phase 0 when k was a
    multiple of the period (n = 2 m + 2 with period 2: every row kept was
    phase 0)."""
    m = 6000
    n = (period - 1) * m + 2 if period <= 3 else 2 * m + 2  # a stride k = ceil(n / m) of 2, 3, 3
    phase = np.arange(n) % period
    ds = dataset.RawDataset({c: phase.astype(float) for c in dataset.SENSOR_COLS})
    sub, _ = dataset.thin(ds, m)
    share = np.bincount(sub.columns["ax_g"].astype(int), minlength=period) / len(sub)
    # each phase's share is a sum of independent draws: 1/period within 6 binomial sigmas
    sd = np.sqrt((1 / period) * (1 - 1 / period) / m)
    assert np.all(np.abs(share - 1 / period) <= 6 * sd + 1 / m), share


def test_calibrate_and_diagnose_state_the_thinning(run_csv, monkeypatch, capsys):
    from inclino.diagnose import analysis

    ds = dataset.read_raw(str(run_csv))
    cal, rep = calib.fit(ds, "joint", max_rows=len(ds) // 2)
    assert any(f"the run has {len(ds)} rows; {len(ds) // 2} of them were used" in n for n in rep.notes)
    assert rep.rows <= len(ds) // 2 + 1 and cal.data["rows"] == len(ds)
    m = len(ds) // 3
    monkeypatch.setattr(analysis, "MAX_ROWS", m)
    r = analysis.diagnose(ds)
    assert any(f"; {m} of them were used" in n for n in r.baseline["selection"]["notes"])


def test_progress_lines_off_a_terminal(run_csv, tmp_path):
    env = dict(os.environ, INCLINO_PROGRESS_PERIOD="0.05")
    r = subprocess.run([sys.executable, "-m", "inclino", "calibrate", str(run_csv), "-o", str(tmp_path / "c.json")],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0
    lines = r.stderr.splitlines()
    assert lines and all(l.startswith("inclino: calibrate: joint fit of ") and "elapsed" in l for l in lines)
    r = subprocess.run([sys.executable, "-m", "inclino", "attitude", str(run_csv), "-o", str(tmp_path / "a.csv")],
                       capture_output=True, text=True)
    assert r.returncode == 0 and r.stderr == ""  # short work with the default period: silent


@pytest.mark.parametrize("opt,value", [("--field", "-50000"), ("--dip", "500"), ("--field", "nan"),
                                       ("--declination", "1e999")])
def test_acquire_header_options_follow_the_header_rules(tmp_path, capsys, opt, value):
    out = tmp_path / "run.csv"
    rc = cli.main(["acquire", "--port", str(tmp_path / "no-port"), "--procedure", "twelve-position",
                   "-o", str(out), opt, value])
    assert rc == 2
    _one_error(capsys.readouterr().err, f"{opt} ")
    assert not out.exists()


def test_progress_bar_on_a_terminal(monkeypatch):
    import pty
    import time

    from inclino import progress

    monkeypatch.setenv("INCLINO_PROGRESS_PERIOD", "0.05")
    master, slave = pty.openpty()
    term = os.fdopen(slave, "w")
    try:
        n = int(RNG.integers(3, 9))
        with progress.bar(n, "attitude run.csv", unit=" rows", stream=term) as b:
            for _ in range(n):
                time.sleep(0.06)
                b.update(1)
        with progress.phase("calibrate: joint fit of run.csv", stream=term):
            time.sleep(0.3)
        term.flush()
        seen = os.read(master, 1 << 16)
    finally:
        term.close()
        os.close(master)
    # on a terminal tqdm redraws one line in place (carriage returns), no line per update
    assert b"\r" in seen and b"attitude run.csv:" in seen and f"/{n} [".encode() in seen
    assert b"calibrate: joint fit of run.csv: 00:00 elapsed" in seen and b"\n" not in seen.replace(b"\r\n", b"")


def _drain(fd) -> bytes:
    """All a pseudo-terminal's master end holds once its slave end is closed."""
    import select

    data = b""
    while select.select([fd], [], [], 5.0)[0]:
        try:
            chunk = os.read(fd, 1 << 16)
        except OSError:  # EIO: the slave is closed and everything was read
            break
        if not chunk:
            break
        data += chunk
    return data


def _screen(data: str) -> list[str]:
    """The lines a terminal shows for this output (carriage return: back to
    the line's start, overwriting; newline: the next line)."""
    lines, cur, col = [], [], 0
    for ch in data:
        if ch == "\r":
            col = 0
        elif ch == "\n":
            lines.append("".join(cur).rstrip())
            cur, col = [], 0
        else:
            if col < len(cur):
                cur[col] = ch
            else:
                cur.append(ch)
            col += 1
    return lines + ["".join(cur).rstrip()]


@pytest.mark.parametrize("work", ["phase", "bar"])
def test_a_result_after_progress_starts_on_a_clean_line(monkeypatch, work):
    """The status a phase or a bar showed on the terminal is gone when the
    result is printed: `cal.json: ...` never runs into `00:05 elapsed`."""
    import pty
    import time

    from inclino import progress

    monkeypatch.setenv("INCLINO_PROGRESS_PERIOD", "0.05")
    master, slave = pty.openpty()
    term = os.fdopen(slave, "w")
    try:
        if work == "phase":
            with progress.phase("calibrate: joint fit of run.csv", stream=term):
                time.sleep(0.4)
        else:
            with progress.bar(4, "reading run.csv", unit=" rows", stream=term) as b:
                for _ in range(4):
                    time.sleep(0.06)
                    b.update(1)
        term.write("cal.json: joint calibration\n")
        term.flush()
        term.close()  # then everything written is read back, however the terminal chunked it
        seen = _drain(master).decode()
    finally:
        if not term.closed:
            term.close()
        os.close(master)
    assert "elapsed" in seen or "reading run.csv" in seen  # the status was shown
    screen = _screen(seen)
    assert "cal.json: joint calibration" in screen, screen


def test_new_output_beside_a_vanished_input_is_written(tmp_path):
    out = tmp_path / "new.csv"
    safeio.write_output(str(out), "x\n", inputs=[str(tmp_path / "gone.csv"), None, "-"])
    assert out.read_text() == "x\n"


@pytest.mark.parametrize("value", ["1", "0", "-5", "1001", "1000000000"])
def test_bootstrap_option_rule(run_csv, tmp_path, capsys, value):
    assert cli.main(["calibrate", str(run_csv), "--bootstrap", value, "-o", str(tmp_path / "c.json")]) == 2
    _one_error(capsys.readouterr().err, f"--bootstrap {value}: refits, 2-1000")
    assert not (tmp_path / "c.json").exists()


def test_turntable_reading_a_little_past_vertical_is_accepted(tmp_path):
    inc, azi, tf, g, b = _rows(4)
    inc[0], inc[1] = -float(RNG.uniform(0, 5)), 180 + float(RNG.uniform(0, 5))
    p = tmp_path / "v.csv"
    p.write_text(_csv_text(inc, azi, tf, g, b))
    assert dataset.read_raw(str(p)).columns["inc_deg"].tolist() == inc.tolist()


def test_trajectory_output_that_is_a_survey_input_is_refused(tmp_path, capsys):
    src = tmp_path / "survey.csv"
    src.write_text("md_m,inc_deg,azi_deg\n0,0,0\n100,10,45\n")
    before = src.read_bytes()
    for argv in (["-o", str(src)], ["-o", str(tmp_path / "t.csv"), "--las", str(src)]):
        assert cli.main(["trajectory", str(src), *argv]) == 2
        _one_error(capsys.readouterr().err, "it is the input file")
    assert src.read_bytes() == before and not (tmp_path / "t.csv").exists()


# ------------------------------------------------------------ the rules' edges
def _documented_rules() -> dict:
    """docs/dataset.md's table of rules: field -> (low, high), low None for '> 0'."""
    import pathlib
    import re

    doc = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "dataset.md").read_text()
    rules = {}
    for line in doc.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")] if line.strip().startswith("| `") else []
        if len(cells) != 2:
            continue
        num = r"(−?[\d ]+(?:\.\d+)?)"
        m = re.match(r"> 0 and ≤ " + num, cells[1]) or re.match(num + r" … " + num, cells[1])
        if not m:
            continue
        vals = [float(g.replace("−", "-").replace(" ", "")) for g in m.groups()]
        lo, hi = (None, vals[0]) if cells[1].startswith(">") else vals
        for key in re.findall(r"`(\w+)`", cells[0]):
            rules[key] = (lo, hi)
    return rules


def _rule_cases():
    doc = _documented_rules()
    assert len(doc) >= 11 and doc["dip_deg"] == (-90.0, 90.0) and doc["field_nT"] == (None, 200000.0)
    for key in dataset.RULES:
        # the documented rule where the table gives one; else the rule as RULES and POSITIVE state it
        lo, hi = doc.get(key) or (None if key in dataset.POSITIVE else dataset.RULES[key][0], dataset.RULES[key][1])
        step = max(abs(lo or 0.0), abs(hi), 1.0) * 1e-6
        edges = [(hi, True), (hi + step, False)]
        if lo is None:  # > 0
            edges += [(1e-9, True), (0.0, False), (-1e-9, False)]
        else:
            edges += [(lo, True), (lo - step, False)]
        for value, ok in edges:
            if key in dataset.NUMERIC_META:
                yield pytest.param("header", key, value, ok, id=f"header-{key}-{value:g}")
            if key in dataset.OPTIONAL_COLS:
                yield pytest.param("column", key, value, ok, id=f"column-{key}-{value:g}")


@pytest.mark.parametrize("where,key,value,ok", list(_rule_cases()))
def test_every_rule_is_inclusive_at_both_ends(tmp_path, where, key, value, ok):
    """Every rule at its ends as docs/dataset.md's table states it (the
    expectations come from the documentation, not from dataset.RULES), for
    every header key and column that has one: both ends read, a millionth
    beyond either refused with the line and the rule named (a quantity that
    must be > 0: any positive value read, 0 refused); check_meta holds an
    option to the same rule."""
    inc, azi, tf, g, b = _rows(3, seed=11)
    text = _csv_text(inc, azi, tf, g, b, meta="")
    lines = text.splitlines()
    if where == "header":
        lines.insert(0, f"# {key}={value!r}")
    else:
        col = lines[0].split(",").index(key)
        cells = lines[2].split(",")
        cells[col] = repr(value)
        lines[2] = ",".join(cells)
    p = tmp_path / "edge.csv"
    p.write_text("\n".join(lines) + "\n")
    if ok:
        ds = dataset.read_raw(str(p))
        assert (ds.meta[key] if where == "header" else ds.columns[key][1]) == value
        dataset.check_meta(key, value, "--option")
    else:
        line = 1 if where == "header" else 3
        with pytest.raises(DataError, match=f"edge.csv:{line}: .*out of range: {key} must be"):
            dataset.read_raw(str(p))
        with pytest.raises(DataError, match=f"--option .* out of range: {key}"):
            dataset.check_meta(key, value, "--option")


def test_line_length_limit_is_exact(tmp_path):
    """A line of MAX_LINE_CHARS characters (newline included) is read, one
    more is refused naming the line."""
    inc, azi, tf, g, b = _rows(3, seed=12)
    body = _csv_text(inc, azi, tf, g, b, meta="")
    n = dataset.MAX_LINE_CHARS
    ok, long = tmp_path / "ok.csv", tmp_path / "long.csv"
    ok.write_text("#" + "x" * (n - 2) + "\n" + body)
    long.write_text("#" + "x" * (n - 1) + "\n" + body)
    assert len(dataset.read_raw(str(ok))) == 3
    with pytest.raises(DataError, match=f"long.csv:1: line longer than {n} characters"):
        dataset.read_raw(str(long))


def test_thinning_note_names_the_rows_kept():
    ds = dataset.RawDataset({c: np.arange(100.0) for c in dataset.SENSOR_COLS})
    assert len(dataset.RawDataset()) == 0
    sub, note = dataset.thin(ds, 30)
    assert len(sub) == 30 and np.all(np.diff(sub.columns["ax_g"]) > 0)
    assert note.startswith("the run has 100 rows; 30 of them were used, one drawn at random from each of 30 "
                           "equal stretches of the run (stratified, seed ")
    assert dataset.thin(ds, 100) == (ds, None)


def test_trajectory_and_compare_show_progress_off_a_terminal(tmp_path):
    """The survey commands' long work (reading, the path, writing; the
    pairing and the error model) shows its status lines on stderr."""
    n = 3000
    md = np.arange(n, dtype=float)
    inc = np.clip(md / 30.0, 0, 60)
    for name, az in (("a.csv", 40.0), ("b.csv", 40.05)):
        (tmp_path / name).write_text("md_m,inc_deg,azi_deg\n" + "".join(
            f"{m:g},{i:.3f},{az}\n" for m, i in zip(md, inc)))
    # a status line every millisecond: reading 3000 stations can take under 10 ms on an idle machine,
    # so a 10 ms period left the reading phase without a line now and then
    env = dict(os.environ, INCLINO_PROGRESS_PERIOD="0.001")
    for argv, phases in (
            (["trajectory", str(tmp_path / "a.csv"), "--declination", "2", "-o", str(tmp_path / "t.csv")],
             ("reading", "trajectory of 3000 stations", "writing 3000 stations")),
            (["compare", str(tmp_path / "a.csv"), str(tmp_path / "b.csv"), "--tool-model", "iscwsa-mwd-rev5",
              "--declination", "2", "--dip", "60", "--field", "50000", "--json"],
             ("comparing 3000 and 3000 stations",))):
        r = subprocess.run([sys.executable, "-m", "inclino", *argv], capture_output=True, text=True, env=env)
        assert r.returncode in (0, 1), r.stderr
        lines = r.stderr.splitlines()
        assert lines and all(l.startswith("inclino: ") and "elapsed" in l for l in lines), r.stderr
        for p in phases:
            assert any(p in l for l in lines), (p, r.stderr)


@pytest.mark.parametrize("n", [40_002, 80_000, 80_001, 120_003])
@pytest.mark.parametrize("period", [2, 3, 4, 7])
def test_thinning_keeps_every_phase_of_a_repeated_run(n, period):
    """A run whose rows repeat a pattern of `period` rows (alternating poses,
    a pose table taken again and again), thinned to 40 000 rows: each phase
    of the pattern keeps its share (1/period of the rows, within 5 binomial
    standard deviations), also where n is a multiple of the period times the
    stride a fixed stride would take (every 2nd row of 40 002 rows kept one
    pose of an alternating run)."""
    m = 40_000
    keep = dataset.thin_rows(n, m)
    assert len(keep) == m and np.all(np.diff(keep) > 0) and keep[0] >= 0 and keep[-1] < n
    counts = np.bincount(keep % period, minlength=period)
    sd = math.sqrt(m * (1 / period) * (1 - 1 / period))
    assert np.all(np.abs(counts - m / period) < 5 * sd), counts
    assert np.array_equal(keep, dataset.thin_rows(n, m))  # seeded: the same file, the same rows


def test_checks_see_every_phase_of_a_repeated_run():
    """The checks' rows on a run of 400 001 rows (beyond CHECK_ROWS: thinned)
    whose accelerometer rows repeat a pattern of three, two of every three
    rows logged in mg where the header says g: the units error is found. With
    every 3rd row (the stride that fits 200 000 rows into 400 001) the checks
    saw only the rows in g and passed the run."""
    from inclino import checks

    n = 400_001
    rng = np.random.default_rng(3)
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = rng.standard_normal((n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    acc = u * np.where(np.arange(n) % 3 == 0, 1.0, 1000.0)[:, None]
    cols = {"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": 50_000 * w[:, 0], "my_nT": 50_000 * w[:, 1], "mz_nT": 50_000 * w[:, 2]}
    ds = dataset.RawDataset(cols, {"gravity_g": 1.0, "field_nT": 50_000.0})
    assert n > checks.CHECK_ROWS and -(-n // checks.CHECK_ROWS) == 3
    rep = checks.run(ds)
    assert any(f.check == "units" and f.level == "error" and f.triad == "acc" for f in rep.findings), \
        [f.message for f in rep.findings]


@pytest.mark.parametrize("cmd", [["attitude", "{run}", "--cal", "{cal}", "-o", "{out}"],
                                 ["download", "--port", "/nonexistent", "--cal", "{cal}"],
                                 ["verify", "--port", "/nonexistent", "--cal", "{cal}"]])
def test_a_calibration_file_that_is_not_there_is_bad_input(tmp_path, capsys, cmd):
    """A CAL.json that cannot be opened is a file that cannot be read: exit 2
    (docs/cli.md), as a missing --prior or dataset is, before any port is
    opened; a corrupt one stays exit 3 (calibration refused)."""
    from inclino.cli import main

    run = tmp_path / "run.csv"
    run.write_text("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0,0,1,20000,0,40000\n")
    args = [a.format(run=run, cal=tmp_path / "absent.json", out=tmp_path / "a.csv") for a in cmd]
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot read calibration" in err[0], err
    (tmp_path / "absent.json").write_text("{not json")
    assert main(args) == 3
