"""`inclino demo` with no arguments: the whole bench on the emulated probe
(acquire on the emulated turntable, joint fit, download, verify, both
acceptance grids, figures) into ./inclino-demo; `--core` keeps the poses
table.  Checked by exit status and by the files written, read back through
the library's own readers; the console wording is free to change."""
import json

import numpy as np

from inclino import cli
from inclino.procedures import demo
from inclino.engines import golden
from inclino.procedures.accept import GRIDS, grid_points
from inclino.procedures.accept_result import AcceptResult
from inclino.formats.calfile import Calibration
from inclino.formats.dataset import POSE_COLS, read_raw

FIGURES = ("fluxgate_sphere.png", "run_circles.png", "circles.png", "errors_li2021.png", "errors_ren2014.png")


def test_demo_runs_the_whole_bench(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["demo", "--quiet"]) == 0
    capsys.readouterr()
    d = tmp_path / "inclino-demo"
    assert sorted(p.name for p in d.iterdir()) == sorted(
        ("run.csv", "cal.json", "accept_li2021.json", "accept_ren2014.json") + FIGURES)
    for name in FIGURES:
        data = (d / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 1000, name
    # the run: a raw dataset with poses, readings at many orientations
    run = read_raw(str(d / "run.csv"))
    assert all(c in run.columns for c in POSE_COLS) and len(run) >= 24
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
        assert len(a.points) == len(grid_points(grid))
        assert [(p["set_inc"], p["set_azi"]) for p in a.points] == [(p.set_inc, p.set_azi) for p in
                                                                      grid_points(grid)]
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


def test_temperature_demo_fits_the_terms_of_an_emulated_chamber_run(tmp_path):
    """`inclino demo --temperature`'s steps, with two set points to keep it short."""
    from inclino.procedures import demo_temp

    said = []
    r = demo_temp.run(str(tmp_path), tempco_draw=int(np.random.default_rng().integers(1000)),
                      setpoints=(10.0, 40.0), quiet=True, say=said.append)
    assert r["passed"] and r["temperature"]["order"] in (1, 2) and r["gain"] >= 10.0
    assert Calibration.load(str(tmp_path / "cal_temperature.json")).temperature["t_ref_c"] == 25.0
    assert r["diagnose_temperature_effects"]["as acquired"]           # the run shows them ...
    assert any(s.startswith("[4/4]") for s in said) and said[-1].startswith("Summary: order")
