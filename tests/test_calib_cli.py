"""`inclino calibrate`: output file, report, errors and exit statuses."""
import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

from inclino.formats.calfile import Calibration
from inclino.benchmarks import calibration as bench
from inclino.calib import runs
from inclino.cli import main
from inclino.formats.dataset import write_raw
from inclino.model.scenario import generate_raw, load_scenario


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("cal")
    s = bench.bench_probe(linear=True)
    run = bench.emulated_run(s, bench.calibration_poses(), seed=21)
    write_raw(str(d / "run.csv"), run)
    nopose = bench.emulated_run(s, runs.multi_position(80), seed=22)
    for c in ("inc_deg", "azi_deg", "tf_deg"):
        del nopose.columns[c]
    write_raw(str(d / "nopose.csv"), nopose)
    few = generate_raw(s, *[p[:5] for p in runs.multi_position(60)])
    write_raw(str(d / "few.csv"), few)
    same = generate_raw(load_scenario("ideal"), [30.0] * 20, [40.0] * 20, [50.0] * 20)
    write_raw(str(d / "same.csv"), same)
    return d


@pytest.mark.parametrize("method", ["joint", "ren2014", "li2021", "guo2009"])
def test_calibrate_writes_a_loadable_file(data, method, capsys):
    out = data / f"cal-{method}.json"
    rc = main(["calibrate", str(data / "run.csv"), "--method", method, "-o", str(out), "--bootstrap", "8"])
    text = capsys.readouterr().out
    assert rc == 0, text
    cal = Calibration.load(str(out))
    d = json.loads(out.read_text())
    assert cal.method == method and d["probe_serial"] == "1001"
    assert d["data"]["sha256"] == hashlib.sha256((data / "run.csv").read_bytes()).hexdigest()
    assert d["fixed"]["acc_m"][0] == round(d["acc_m"][0][0] * 2**29)
    assert d["report"]["method"] == method and d["report"]["passed"] is True
    last, c = text.strip().splitlines()[-1], d["report"]["closest"]
    assert last.startswith("verdict: PASS: every check within its limit; the nearest") and c["value"] <= c["limit"]
    assert last.endswith(f"{c['what']}, {c['value']:.4g} against {c['limit']:g}")


def test_calibrate_json_output(data, capsys):
    out = data / "cal.json"
    rc = main(["calibrate", str(data / "run.csv"), "-o", str(out), "--json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["method"] == "joint" and d["report"]["mode"] == "poses"
    assert len(d["report"]["uncertainty"]["sigma"]) == 24


def test_calibrate_without_poses_uses_the_invariants(data, capsys):
    # no poses, no prior: the block's common rotation is unobservable; the
    # report says so, its prediction includes the mounting tolerance, and the
    # verdict refuses azimuth until that tolerance is accepted
    rc = main(["calibrate", str(data / "nopose.csv"), "-o", str(data / "np.json"), "--json"])
    d = json.loads(capsys.readouterr().out)
    u = d["report"]["uncertainty"]
    assert rc == 1 and d["report"]["mode"] == "invariants"
    assert "common rotation" in u["unobservable"] and u["mount_tolerance_deg"] == 0.3
    assert any(r.startswith("not fit for azimuth") for r in d["report"]["reasons"])
    assert u["predicted_azi_rms_deg"] > 10 * u["predicted_azi_rms_fit_only_deg"]
    rc = main(["calibrate", str(data / "nopose.csv"), "-o", str(data / "np.json"), "--json",
               "--accept-mount-tolerance", "--mount-tolerance-deg", "0.1"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0, d["report"]["reasons"]
    assert d["report"]["uncertainty"]["mount_tolerance_deg"] == 0.1
    # with a prior (the turntable run's calibration of the same probe) it passes as is
    assert main(["calibrate", str(data / "run.csv"), "-o", str(data / "prior.json")]) == 0
    capsys.readouterr()
    rc = main(["calibrate", str(data / "nopose.csv"), "-o", str(data / "np2.json"), "--json",
               "--prior", str(data / "prior.json")])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["report"]["uncertainty"]["prior"] is True, d["report"]["reasons"]


@pytest.mark.parametrize("args, code, message", [
    (["nopose.csv", "--method", "li2021"], 2, "li2021 needs the turntable pose columns"),
    (["nopose.csv", "--method", "guo2009"], 2, "guo2009 needs the turntable pose columns"),
    (["few.csv"], 2, "joint needs >= 8 readings"),
    (["few.csv", "--method", "li2021"], 2, "missing position"),
    (["same.csv"], 3, "singular"),
    (["absent.csv"], 2, "cannot read"),
    (["nopose.csv", "--prior", "absent.json"], 2, "--prior: cannot read"),
    (["nopose.csv", "--mount-tolerance-deg", "-1"], 2, "--mount-tolerance-deg"),
])
def test_calibrate_errors(data, args, code, message, capsys):
    out = data / "err.json"
    out.write_text("previous")
    argv = ["calibrate", str(data / args[0]), *args[1:], "-o", str(out)]
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == code
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert out.read_text() == "previous"  # never half-written, never clobbered
    assert not list(data.glob(".cal-*"))  # no temporary left behind


def test_calibrate_subprocess_one_line_error(data):
    p = subprocess.run([sys.executable, "-m", "inclino", "calibrate", str(data / "same.csv"), "-o",
                        str(data / "x.json")], capture_output=True, text=True)
    assert p.returncode == 3 and p.stderr.startswith("inclino: error:") and p.stderr.count("\n") == 1
    assert not (data / "x.json").exists()


def test_calfile_rejects_a_stale_fixed_image(data, capsys):
    src = data / "stale-src.json"  # its own file: the tests run in any order
    assert main(["calibrate", str(data / "run.csv"), "-o", str(src)]) == 0
    capsys.readouterr()
    d = json.loads(src.read_text())
    d["acc_m"][0][0] += 1e-3
    from inclino.errors import CalibrationError

    with pytest.raises(CalibrationError, match="fixed-point image does not match"):
        Calibration.from_json(json.dumps(d))
    del d["fixed"], d["report"], d["data"]  # a format-1 file of the first kind still loads
    assert Calibration.from_json(json.dumps(d)).acc_m[0][0] == d["acc_m"][0][0]


@pytest.mark.heavy
def test_bench_calibration_small(small_calibration_bench):
    d = json.loads(small_calibration_bench.to_json())  # bench_calibration(n_runs=1, no peer, 1 temperature probe)
    m = d["methods"]
    for k in ("joint", "ren2014", "li2021", "guo2009"):
        assert m[k]["runs"] == 1 and m[k]["azi_rms_deg"] > 0
    assert m["joint"]["azi_rms_deg"] < min(m[k]["azi_rms_deg"] for k in ("ren2014", "li2021", "guo2009"))
    # one run's grid RMS scatters ~5x between seeds (docs/calibration.md; measured with n_runs=1,
    # seeds 100-104: 0.29, 1.62, 0.61, 0.77, 0.84), so the band is not a physics check: the run is
    # seeded (seed 100, a lucky one for the nonlinear joint), repeats bit for bit on this machine,
    # and its measured ratio 0.292 is pinned within 5 % -- room for another NumPy/BLAS's rounding
    # in the fits, far less than any change to the fit or to the bound moves it
    assert d["met"]["ratio_to_cramer_rao"] == pytest.approx(0.2922, rel=0.05)
    fr = d["cramer_rao"]["firmware_representable"]
    assert fr["azi_rms_deg"] >= d["cramer_rao"]["azi_rms_deg"] and fr["azi_linear_bias_part_deg"] > 0
    assert d["papers_measured"]["li2021"].startswith("azimuth RMS 0.82")
    # achieved/predicted and the field fit with a prior are reported (one run: no band asserted)
    pr = d["prediction"]
    for k in ("pose_fit_calibration_grid", "pose_fit_acceptance_grid", "field_fit_with_prior"):
        assert pr[k]["azi"]["runs"] == 1 and pr[k]["azi"]["median_ratio"] > 0
    assert d["field_prior"]["probes"] == 1 and d["field_prior"]["pooled_ratio"] > 0
    t = d["temperature"]
    assert t["probes"] == 1 and len(t["per_probe"]) + len(t["failed_probes"]) == 1
    assert d["met"]["temperature_within_1_2x_room"] == t["passed"]
    assert d["time"] == {"not_run": "time_probes=0"} and d["met"]["time_targets"] is None and not d["passed"]
