"""trajectory on a build-hold-turn well generated here: its positions against
minimum curvature written out in the test, and the summary's wording of a
calibration whose run names no probe serial.  The calibration run is
generated from docs/conventions.md's pose (numpy, no inclino.model)."""
import csv

import numpy as np

from indep import body
from inclino import cli


def _well():
    md = np.arange(0.0, 1800.0 + 1e-9, 30.0)
    inc = np.clip((md - 300.0) / 30.0 * 3.0, 0.0, 45.0)  # vertical, build 3 deg/30 m, hold
    azi = 60.0 + np.clip((md - 1200.0) / 30.0 * 3.0, 0.0, 60.0)  # then turn 3 deg/30 m to 120
    return md, inc, azi


def _min_curvature(md, inc, azi):
    I, A = np.radians(inc), np.radians(azi)
    t = np.column_stack([np.sin(I) * np.cos(A), np.sin(I) * np.sin(A), np.cos(I)])
    pos = np.zeros((len(md), 3))
    for k in range(1, len(md)):
        dl = np.arccos(np.clip(t[k - 1] @ t[k], -1.0, 1.0))
        rf = 1.0 if dl < 1e-12 else 2.0 / dl * np.tan(dl / 2.0)
        pos[k] = pos[k - 1] + (md[k] - md[k - 1]) / 2.0 * (t[k - 1] + t[k]) * rf
    return pos


def _calibration_run(path, rng, n=72):
    k = np.arange(n) + 0.5
    I, A, T = np.degrees(np.arccos(1 - 2 * k / n)), np.mod(k * 137.508, 360), np.mod(k * 222.492 + 17, 360)
    field = 50000.0 * np.array([np.cos(np.radians(45.0)), 0.0, np.sin(np.radians(45.0))])
    acc = body(I, A, T, np.array([0.0, 0.0, 1.0])) @ (np.eye(3) + rng.normal(0, 3e-3, (3, 3))).T \
        + rng.normal(0, 5e-3, 3) + rng.normal(0, 1.5e-4, (n, 3))
    mag = body(I, A, T, field) @ (np.eye(3) + rng.normal(0, 3e-3, (3, 3))).T \
        + rng.normal(0, 300.0, 3) + rng.normal(0, 15.0, (n, 3))
    with open(path, "w") as f:
        f.write("# field_nT=50000\n# dip_deg=45\n# declination_deg=0\n")
        f.write("inc_deg,azi_deg,tf_deg,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n")
        f.writelines(",".join(f"{x:.9g}" for x in r) + "\n" for r in np.column_stack([I, A, T, acc, mag]))


def test_positions_follow_minimum_curvature_and_a_serial_less_calibration_is_named_so(tmp_path, capsys):
    rng = np.random.default_rng(3)
    _calibration_run(tmp_path / "calrun.csv", rng)
    assert cli.main(["calibrate", str(tmp_path / "calrun.csv"), "-o", str(tmp_path / "cal.json")]) in (0, 1)
    capsys.readouterr()
    md, inc, azi = _well()
    tf = np.mod(np.arange(len(md)) * 47.0 + 13.0, 360.0)
    listing = tmp_path / "st.csv"
    with open(listing, "w") as f:
        f.write("md_m,inc_deg,azi_deg,tf_deg\n")
        f.writelines(f"{m:.3f},{i:.9f},{a:.9f},{t:.3f}\n" for m, i, a, t in zip(md, inc, azi, tf))
    out = tmp_path / "traj.csv"
    rc = cli.main(["trajectory", str(listing), "--declination", "0", "--dip", "45", "--field", "50000",
                   "--uncertainty", "--cal", str(tmp_path / "cal.json"), "-o", str(out)])
    text = capsys.readouterr().out
    assert rc == 0
    rows = list(csv.DictReader(ln for ln in open(out) if not ln.startswith("#")))
    got = np.array([[float(r["north_m"]), float(r["east_m"]), float(r["tvd_m"])] for r in rows])
    assert np.abs(got - _min_curvature(md, inc, azi)).max() < 1e-4
    # the run names no serial: said so, not "calibration of probe )"
    assert "calibration of probe (no serial))" in text and "of probe )" not in text, text


def test_a_one_triad_calibration_is_refused_by_the_survey_error_model_naming_why(tmp_path, capsys):
    """An accelerometer-only calibration given to toolmodel, trajectory or
    compare had been refused as 'records no reading noise', and with the
    noise given as 'covariance must be a list of 24, not a list of 12' (exit 3)."""
    rng = np.random.default_rng(8)
    _calibration_run(tmp_path / "both.csv", rng)
    lines = (tmp_path / "both.csv").read_text().splitlines()
    keep = [0, 1, 2, 3, 4, 5]  # the poses and the accelerometer's columns
    (tmp_path / "acc.csv").write_text("\n".join(lines[:3] + [",".join(r.split(",")[i] for i in keep)
                                                            for r in lines[3:]]) + "\n")
    cal = tmp_path / "acc.json"
    assert cli.main(["calibrate", str(tmp_path / "acc.csv"), "-o", str(cal)]) in (0, 1)
    md, inc, azi = _well()
    listing = tmp_path / "st.csv"
    listing.write_text("md_m,inc_deg,azi_deg\n" + "".join(f"{m},{i},{a}\n" for m, i, a in zip(md, inc, azi)))
    capsys.readouterr()
    for argv in (["toolmodel", "--cal", str(cal), "--dip", "45", "--field", "50000", "-o", str(tmp_path / "t.json")],
                 ["toolmodel", "--cal", str(cal), "--dip", "45", "--field", "50000", "--acc-noise", "1e-4",
                  "--mag-noise", "10", "-o", str(tmp_path / "t.json")],
                 ["trajectory", str(listing), "--declination", "0", "--uncertainty", "--cal", str(cal),
                  "-o", str(tmp_path / "o.csv")],
                 ["compare", str(listing), str(listing), "--cal", str(cal), "--acc-noise", "1e-4", "--mag-noise", "10"]):
        rc = cli.main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and "is an accelerometer-only calibration" in err[0], (argv[0], rc, err)
