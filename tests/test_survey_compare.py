"""Done-when: `compare` of two surveys of the same stations with the same
calibration passes at >= 95 % of the stations.  The emulated typical
probe, calibrated (joint) and the calibration downloaded, surveys the
stations going in (depth increasing, one file continued with --append) and
coming out (depth decreasing: an out-run), at a new toolface each time;
`compare --cal` pairs them by depth with the noise the calibration's fit
report measured.  With the noise taken as zero (what the tools assumed
before) the same pairs fail."""
import json

import numpy as np

from inclino import cli
from inclino.benchmarks import survey as sb
from inclino_emu.control import ControlClient
from inclino_emu.runner import Emulator

RNG = np.random.default_rng()
N = 24


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def test_in_run_and_out_run_of_the_same_stations_agree(tmp_path, capsys):
    from inclino.survey import geomag

    seed = int(RNG.integers(1, 1 << 20))
    scen = sb.scenario_file(str(tmp_path / "s.toml"), geomag.normal_gravity_g(sb.LAT))
    cal = str(tmp_path / "cal.json")
    sb.calibrate(scen, cal, seed)
    md = np.sort(RNG.choice(np.arange(30.0, 1500.0, 15.0), N, replace=False))
    inc = RNG.uniform(3, 85, N)
    azi = RNG.uniform(0, 360, N)
    files = {"in": tmp_path / "in.csv", "out": tmp_path / "out.csv"}
    with Emulator(scen, seed=seed, control_port=0, realtime=False) as emu:
        ctl = ControlClient(port=emu.control_port)
        assert run(capsys, "download", "--port", emu.path, "--cal", cal, "--quiet")[0] == 0
        for run_name, order in (("in", range(N)), ("out", reversed(range(N)))):
            for n, i in enumerate(order):
                ctl.call("move", inc=float(inc[i]), azi=float(azi[i]), tf=float(RNG.uniform(0, 360)))
                run(capsys, "survey", "--port", emu.path)  # the first survey after a move settles the filters
                rc, out, err = run(capsys, "survey", "--port", emu.path, "--md", md[i], "-o", files[run_name],
                                   *(["--append"] if n else []))
                assert rc == 0, err
        ctl.close()
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal, "--json")
    r = json.loads(out)
    assert r["runs"] == ["in-run", "out-run"] and r["summary"]["pairs"] == N, out + err
    assert r["summary"]["passed_fraction"] >= 0.95, [s for s in r["stations"] if s["verdict"] != "PASS"]
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal)
    assert "noise per survey" in out and "fit report" in out
    # the noise taken as zero: the differences the readings' noise makes are outside the expected spread
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal, "--acc-noise", 0, "--mag-noise", 0,
                       "--json")
    zero = json.loads(out)
    assert rc == 1 and zero["summary"]["passed_fraction"] < r["summary"]["passed_fraction"]
