"""The raw dataset format, `inclino attitude`, and the CLI's error contract:
one line on stderr, a documented exit status, never a traceback."""
import csv
import subprocess
import sys

import numpy as np
import pytest

from inclino import cli
from inclino.formats import dataset
from inclino.engines import attitude as engines, reference
from inclino.formats.calfile import Calibration


def _write(path, text):
    path.write_text(text)
    return str(path)


def _dataset(tmp_path, n=40, seed=3):
    rng = np.random.default_rng(seed)
    inc = rng.uniform(2, 178, n)
    azi = rng.uniform(0, 360, n)
    tf = rng.uniform(0, 360, n)
    g, b = reference.body_vectors(inc, azi, tf, 52000.0, 45.1)
    cols = {"t_s": np.arange(n, dtype=float), "inc_deg": inc, "azi_deg": azi, "tf_deg": tf,
            "temp_c": np.full(n, 25.0), "ax_g": g[:, 0], "ay_g": g[:, 1], "az_g": g[:, 2],
            "mx_nT": b[:, 0], "my_nT": b[:, 1], "mz_nT": b[:, 2]}
    ds = dataset.RawDataset(cols, {"field_nT": 52000.0, "dip_deg": 45.1, "source": "test"})
    p = tmp_path / "run.csv"
    dataset.write_raw(str(p), ds)
    return p, ds


def test_roundtrip_and_any_column_order(tmp_path):
    p, ds = _dataset(tmp_path)
    back = dataset.read_raw(str(p))
    assert back.meta["dip_deg"] == 45.1 and back.meta["source"] == "test"
    for c, v in ds.columns.items():
        assert np.allclose(back.columns[c], v, rtol=0, atol=0)
    # shuffled columns, an extra column, no pose columns
    text = "# field_nT=50000\nmz_nT,extra,ax_g,my_nT,ay_g,mx_nT,az_g\n3,x,0.1,2,0.2,1,0.9\n"
    d2 = dataset.read_raw(_write(tmp_path / "f.csv", text))
    assert d2.acc.tolist() == [[0.1, 0.2, 0.9]] and d2.mag.tolist() == [[1.0, 2.0, 3.0]]
    assert not d2.has_pose


@pytest.mark.parametrize("body,needle", [
    ("ax_g,ay_g,az_g,mx_nT,my_nT\n1,2,3,4,5\n", "missing column(s) mz_nT"),
    ("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0,0,1,1,2,3\n0,0,abc,1,2,3\n", ":3: column az_g: 'abc' is not a number"),
    ("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0,0,1,nan,2,3\n", ":2: column mx_nT: 'nan' is not a finite number"),
    ("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0,0,1\n", ":2: 3 cells, the header has 6"),
    ("# only a comment\n", "no header row"),
    ("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n", "no data rows"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, body, needle):
    p = _write(tmp_path / "bad.csv", body)
    rc = cli.main(["attitude", p, "-o", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err
    assert rc == 2
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err


def test_missing_file_and_binary_file(tmp_path, capsys):
    assert cli.main(["attitude", str(tmp_path / "nope.csv"), "-o", "-"]) == 2
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x81garbage")
    assert cli.main(["attitude", str(tmp_path / "bin.csv"), "-o", "-"]) == 2
    err = capsys.readouterr().err
    assert err.count("inclino: error:") == 2 and "Traceback" not in err


def test_process_level_no_traceback(tmp_path):
    p = _write(tmp_path / "bad.csv", "ax_g\n1\n")
    r = subprocess.run([sys.executable, "-m", "inclino", "attitude", p, "-o", "-"], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.startswith("inclino: error:") and "Traceback" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "inclino", "attitude"], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_attitude_engines(tmp_path):
    p, ds = _dataset(tmp_path)
    outs = {}
    for eng in engines.ENGINES:
        o = tmp_path / f"{eng}.csv"
        assert cli.main(["attitude", str(p), "--engine", eng, "-o", str(o)]) == 0
        with open(o) as f:
            rows = list(csv.DictReader(f))
        assert len(rows) == len(ds)
        outs[eng] = rows
    assert outs["firmware"] == outs["golden"]  # bit-exact engines print identical text
    for k in ("inc_deg", "azi_deg", "tf_deg", "dip_deg"):
        f = np.array([float(r[k]) for r in outs["firmware"]])
        r = np.array([float(r[k]) for r in outs["reference"]])
        truth = {"inc_deg": ds.columns["inc_deg"], "azi_deg": ds.columns["azi_deg"],
                 "tf_deg": ds.columns["tf_deg"], "dip_deg": np.full(len(ds), 45.1)}[k]
        assert np.abs(reference.angle_diff(r, truth)).max() < 1e-6  # float on unquantised truth (6 decimals)
        assert np.abs(reference.angle_diff(f, truth)).max() < 0.05  # counts limit the fixed engine
    assert all(int(r["flags"]) == 0 for r in outs["firmware"])


def test_attitude_with_calibration_file(tmp_path):
    p, ds = _dataset(tmp_path)
    m = np.array([[1.02, 0.01, 0.0], [0.0, 0.98, 0.005], [0.0, 0.0, 1.01]])
    cal = Calibration(acc_m=m.tolist(), acc_b=[0.01, -0.02, 0.0], mag_m=np.eye(3).tolist(),
                      mag_b=[100.0, 0.0, -50.0], method="test")
    cp = tmp_path / "cal.json"
    cp.write_text(cal.to_json())
    o = tmp_path / "o.csv"
    assert cli.main(["attitude", str(p), "--cal", str(cp), "-o", str(o)]) == 0
    got = np.loadtxt(o, delimiter=",", skiprows=1, usecols=0)
    want = engines.run(ds.acc, ds.mag, cal, "golden")["inc_deg"]
    assert np.allclose(got, want, atol=1e-6)
    # corrupt and singular calibrations: exit 3, nothing written
    cp.write_text("{not json")
    o2 = tmp_path / "o2.csv"
    assert cli.main(["attitude", str(p), "--cal", str(cp), "-o", str(o2)]) == 3
    bad = Calibration(acc_m=np.zeros((3, 3)).tolist())
    d = __import__("json").loads(cal.to_json())
    d["acc_m"] = bad.acc_m
    cp.write_text(__import__("json").dumps(d))
    assert cli.main(["attitude", str(p), "--cal", str(cp), "-o", str(o2)]) == 3
    assert not o2.exists()


def test_demo_and_bench_cli(capsys):
    assert cli.main(["demo", "--core"]) == 0
    out = capsys.readouterr().out
    assert "near-vertical" in out and " 90.0    0.0  180.0 |" in out
    assert cli.main(["bench", "accuracy", "--json"]) == 0
    d = __import__("json").loads(capsys.readouterr().out)
    for k in ("inc_max_deg", "inc_rms_deg", "azi_max_deg", "azi_rms_deg", "tf_max_deg", "tf_rms_deg"):
        assert k in d and np.isfinite(d[k])
    assert set(d["sources"]) == {"input_quantisation", "coefficient_quantisation", "algorithm"}
    assert d["pass"] == all(d[k] <= v for k, v in d["targets"].items())
