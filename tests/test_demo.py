"""`inclino demo` with no arguments: the whole bench on the emulated probe
(acquire on the emulated turntable, joint fit, download, verify, both
acceptance grids, figures) into ./inclino-demo; `--core` keeps the poses
table.  Checked by exit status and by the files written, read back through
the library's own readers; the console wording is free to change."""
import json

import numpy as np
import pytest

from inclino import cli
from inclino.procedures import demo
from inclino.engines import golden
from inclino.procedures.accept import GRIDS, grid_points
from inclino.procedures.accept_result import AcceptResult
from inclino.formats.calfile import Calibration
from inclino.formats.dataset import POSE_COLS, read_raw

FIGURES = ("fluxgate_sphere.png", "circles.png", "errors_li2021.png", "errors_ren2014.png")  # and run_circles.png
# when the adaptive run happens to hold a circle rotation (plots.circle_groups)


def test_demo_runs_the_whole_bench(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["demo", "--quiet"]) == 0
    capsys.readouterr()
    d = tmp_path / "inclino-demo"
    from inclino.procedures.plots import circle_groups

    run = read_raw(str(d / "run.csv"))
    circles = ("run_circles.png",) if circle_groups(*(run.columns[c] for c in POSE_COLS)) else ()
    assert sorted(p.name for p in d.iterdir()) == sorted(
        ("run.csv", "cal.json", "accept_li2021.json", "accept_ren2014.json") + FIGURES + circles)
    for name in FIGURES:
        data = (d / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 1000, name
    # the run: a raw dataset with poses, an adaptive run of at least its minimum of poses, at distinct orientations
    from inclino.procedures.adaptive import AdaptivePlan

    run = read_raw(str(d / "run.csv"))
    assert all(c in run.columns for c in POSE_COLS) and len(run) >= AdaptivePlan().min_poses
    poses = np.round(np.column_stack([run.columns[c] for c in POSE_COLS]), 3)
    assert len(np.unique(poses, axis=0)) >= AdaptivePlan().min_poses // 2
    g = np.linalg.norm(run.acc, axis=1)
    assert np.all(np.abs(g - 1.0) < 0.2)  # gravity through an uncalibrated accelerometer
    # the calibration: loads (its fixed-point image checked against the floats), the joint fit of serial 1001
    cal = Calibration.load(str(d / "cal.json"))
    assert cal.method == "joint"
    assert json.loads((d / "cal.json").read_text())["probe_serial"] == "1001"
    # the acceptance results: every grid point measured, the calibration brought the errors down
    for grid in GRIDS:
        a = AcceptResult.load(str(d / f"accept_{grid}.json"))
        assert a.grid == grid and a.passed and not a.survey_mismatches
        want = grid_points(grid, toolfaces=demo.DEMO_TOOLFACES[grid])
        assert len(a.points) == len(want)
        assert [(p["set_inc"], p["set_azi"], p["tf"]) for p in a.points] == [(p.set_inc, p.set_azi, p.tf)
                                                                            for p in want]
        b, f = a.stats["before"], a.stats["after"]
        assert f["azi_rms_deg"] < b["azi_rms_deg"] / 8 and f["inc_rms_deg"] < b["inc_rms_deg"] / 20
    assert AcceptResult.load(str(d / "accept_li2021.json")).circles  # Li's horizontal circles, li2021 only


def test_demo_core_prints_the_library_table(capsys):
    assert cli.main(["demo", "--core", "--dip", "45"]) == 0
    out = capsys.readouterr().out
    r = demo.run(dip_deg=45.0)
    assert out == demo.render(r) + "\n"  # the command is a shell over demo.run/render
    f, e = r.fixed, r.ref
    assert len(f["inc_deg"]) == len(demo.POSES)
    assert np.max(np.abs(np.asarray(f["inc_deg"]) - e["inc_deg"])) < 0.01  # the core's 0.01 deg budget
    assert np.max(np.abs(np.asarray(f["dip_deg"]) - 45.0)) < 0.01
    near = (np.asarray(f["flags"]).astype(int) & golden.F_NEAR_VERTICAL) != 0
    assert list(near) == [i < 0.5 or i > 179.5 for i, _, _ in demo.POSES]


@pytest.mark.heavy
def test_temperature_demo_fits_and_checks_the_terms_of_an_emulated_chamber_run(tmp_path, capsys, rng):
    """`inclino demo --temperature` on a probe drawn now: exit status and the
    files, read back through the library's readers."""
    from inclino.procedures.accept_temp import TempAcceptResult

    out = tmp_path / "demo_t"
    rc = cli.main(["demo", "--chamber", "--quiet", "-o", str(out),
                   "--tempco-draw", str(int(rng.integers(1000)))])
    capsys.readouterr()
    assert rc == 0
    assert sorted(p.name for p in out.iterdir()) == ["accept_temperature.json", "cal_temperature.json",
                                                     "run_temperature.csv"]
    run = read_raw(str(out / "run_temperature.csv"))
    assert run.columns["temp_c"].min() < -4.0 and run.columns["temp_c"].max() > 54.0
    cal = Calibration.load(str(out / "cal_temperature.json"))
    assert cal.temperature["order"] in (1, 2) and cal.temperature["t_ref_c"] == 25.0
    a = TempAcceptResult.from_json((out / "accept_temperature.json").read_text())
    assert a.setpoints_c == [-5.0, 25.0, 55.0] and a.reference_c == 25.0 and not a.survey_mismatches
    # toolfaces 0, 120, 240 by default; the 18 positions at I = 2 deg taken 8 times in all (pooled)
    assert a.passed == (not a.reasons) and len(a.points) == 3 * (3 * 66 + 7 * 18)
    for s in a.setpoints:  # the terms brought the grid's errors down away from 25 degC (the exit status says so too)
        if s["setpoint_c"] != 25.0:
            assert s["with"]["azi_rms_deg"] < s["without"]["azi_rms_deg"]
            assert s["with"]["inc_rms_deg"] < s["without"]["inc_rms_deg"]
