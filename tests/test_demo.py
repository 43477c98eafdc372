"""`inclino demo` with no arguments: the whole bench on the emulated probe
(acquire on the emulated turntable, joint fit, download, verify, both
acceptance grids, figures) into ./inclino-demo; `--core` keeps the poses
table."""
import json
import re

import numpy as np

from inclino import cli


def test_demo_runs_the_whole_bench(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["demo"]) == 0
    out = capsys.readouterr().out
    for k in range(1, 6):
        assert f"[{k}/5]" in out
    assert "verify: storage pass, correction pass" in out
    assert "Li 2021 Table 4 layout" in out and "Li 2021 Table 5 layout" in out
    assert "Ren 2014 Table 1 layout" in out and "Ren 2014 Table 2 layout" in out
    assert out.count("verdict: PASS") == 2 and "Summary" in out
    d = tmp_path / "inclino-demo"
    for name in ("run.csv", "cal.json", "accept_li2021.json", "accept_ren2014.json", "fluxgate_sphere.png",
                 "run_circles.png", "circles.png", "errors_li2021.png", "errors_ren2014.png"):
        assert (d / name).stat().st_size > 1000, name
    cal = json.loads((d / "cal.json").read_text())
    assert cal["method"] == "joint" and cal["probe_serial"] == "1001"
    for grid in ("li2021", "ren2014"):
        a = json.loads((d / f"accept_{grid}.json").read_text())
        b, f = a["stats"]["before"], a["stats"]["after"]
        assert a["passed"] and not a["survey_mismatches"]
        assert f["azi_rms_deg"] < b["azi_rms_deg"] / 8 and f["inc_rms_deg"] < b["inc_rms_deg"] / 20
    secs = float(re.search(r"^  ([0-9.]+) s \(start", out, re.M).group(1))
    assert secs < 120


def test_demo_core_keeps_the_poses_table(capsys):
    assert cli.main(["demo", "--core", "--dip", "45"]) == 0
    out = capsys.readouterr().out
    assert "dip 45 deg" in out and " 90.0    0.0  180.0 |" in out and "near-vertical" in out


def test_temperature_demo_fits_the_terms_of_an_emulated_chamber_run(tmp_path):
    """`inclino demo --temperature`'s steps, with two set points to keep it short."""
    from inclino import demo_temp
    from inclino.calfile import Calibration

    said = []
    r = demo_temp.run(str(tmp_path), tempco_draw=int(np.random.default_rng().integers(1000)),
                      setpoints=(10.0, 40.0), quiet=True, say=said.append)
    assert r["passed"] and r["temperature"]["order"] in (1, 2) and r["gain"] >= 10.0
    assert Calibration.load(str(tmp_path / "cal_temperature.json")).temperature["t_ref_c"] == 25.0
    assert r["diagnose_temperature_effects"]["as acquired"]           # the run shows them ...
    assert any(s.startswith("[4/4]") for s in said) and said[-1].startswith("Summary: order")
