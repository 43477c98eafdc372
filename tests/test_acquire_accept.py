"""inclino acquire / calibrate / download / verify / accept / plot end to end
against the emulated probe over its pseudo-terminal (pyserial on the real
pty, the turntable moved over the control channel), and their refusals."""
import copy
import io
import json
import pathlib
import re
import numpy as np
import pytest

from inclino.procedures import acquire as acq
from inclino.procedures import readings
from inclino.procedures.turntable import ManualTurntable
from inclino import cli
from inclino.formats import dataset
from inclino.engines import reference as ref
from inclino.procedures.accept import AcceptResult, grid_points
from inclino.formats.calfile import Calibration
from inclino.calib import runs
from inclino.link.serial_link import ProbeLink
from inclino_emu.control import ControlClient
from inclino_emu.runner import Emulator
from inclino.model.scenario import generate_raw, load_scenario


@pytest.fixture
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def bench_of(emu):
    return f"127.0.0.1:{emu.control_port}"


def verdict_of(rc, cal_json):
    """calibrate wrote the file and exited on its verdict: 0 passed, 1 written with a failed verdict."""
    rep = json.loads(pathlib.Path(cal_json).read_text())["report"]
    assert rc == (0 if rep["passed"] else 1), (rc, rep["reasons"])
    return rep


def grid_errors(cal, toolfaces=(0.0,)):
    """Azimuth and inclination RMS a calibration leaves on the typical
    probe over the Li grid: noise-free readings, float64."""
    s = copy.deepcopy(load_scenario("typical"))
    s.acc.noise = None
    s.mag.noise = None
    g = runs.li2021_grid(toolfaces)
    ds = generate_raw(s, *g)
    c = cal or Calibration()
    a = ref.attitude(ref.correct(ds.acc, c.acc_m, c.acc_b), ref.correct(ds.mag, c.mag_m, c.mag_b))
    da, di = ref.angle_diff(a["azi"], g[1]), a["inc"] - g[0]
    return float(np.sqrt(np.mean(da ** 2))), float(np.sqrt(np.mean(di ** 2)))


def test_acquire_calibrate_download_verify_accept(emu, capsys, tmp_path):
    run_csv, cal_json = tmp_path / "run.csv", tmp_path / "cal.json"
    rc, out, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench_of(emu), "--procedure",
                       "multi-position", "-o", run_csv, "--quiet")
    assert rc == 0, err
    assert "94 rows" in out and not (tmp_path / "run.csv.part").exists()
    ds = dataset.read_raw(str(run_csv))
    assert len(ds) == 94 and ds.has_pose
    assert ds.meta["probe_serial"] == "1001" and ds.meta["field_nT"] == pytest.approx(50000, abs=1)
    assert ds.meta["dip_deg"] == pytest.approx(60, abs=1e-3) and "bench" in ds.meta["source"]
    assert np.all(np.diff(ds.columns["t_s"]) > 0)  # the probe's own timestamps
    # the rows are the readings at the poses: the typical probe's raw field is within ~1000 nT of the truth
    g, b = ref.body_vectors(ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"], 50000, 60)
    assert np.abs(ds.mag - b).max() < 1500 and np.abs(ds.acc - g).max() < 0.01

    rc, out, err = run(capsys, "calibrate", run_csv, "--method", "joint", "-o", cal_json)
    assert rc == 0, out + err
    cal = Calibration.load(str(cal_json))
    assert cal.probe_serial == "1001"
    # what the fit leaves (noise-free readings of the same probe): far below the uncalibrated probe's error
    azi_id, inc_id = grid_errors(None)
    azi_fit, inc_fit = grid_errors(cal)
    assert azi_fit < azi_id / 10 and inc_fit < inc_id / 10

    rc, out, err = run(capsys, "download", "--port", emu.path, "--cal", cal_json, "--quiet")
    assert rc == 0, err
    rc, out, err = run(capsys, "verify", "--port", emu.path, "--cal", cal_json)
    assert rc == 0 and "correction: pass" in out

    save = tmp_path / "accept.json"
    rc, out, err = run(capsys, "accept", "--port", emu.path, "--bench", bench_of(emu), "--grid", "li2021",
                       "-o", save, "--quiet")
    assert rc == 0, out + err
    assert "Li 2021 Table 5 layout" in out and "verdict: PASS" in out
    r = AcceptResult.load(str(save))
    assert r.before == "identity" and r.after.startswith("as found: joint")
    assert len(r.points) == 66 and r.surveys_checked == 198 and not r.survey_mismatches
    b, a = r.stats["before"], r.stats["after"]
    # before: the uncalibrated probe as the emulator's model predicts it (0.76 deg / 0.25 deg at toolface 0)
    assert b["azi_rms_deg"] == pytest.approx(azi_id, rel=0.1)
    assert b["inc_rms_deg"] == pytest.approx(inc_id, rel=0.1)
    # after: reading noise plus what the fit leaves; > 8x (azimuth) and > 20x (inclination) smaller
    assert a["azi_rms_deg"] < b["azi_rms_deg"] / 8 and a["inc_rms_deg"] < b["inc_rms_deg"] / 20
    assert a["azi_rms_deg"] < 0.15 and a["inc_rms_deg"] < 0.02


def test_accept_downloads_the_file_ren_grid_and_plots(emu, capsys, tmp_path):
    """accept --cal: before = the probe as found, the file downloaded first;
    Ren's signed tilts; the figures."""
    run_csv, cal_json = tmp_path / "run.csv", tmp_path / "cal.json"
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench_of(emu), "--procedure",
                     "twelve-position", "-o", run_csv, "--quiet")
    assert rc == 0, err
    assert len(dataset.read_raw(str(run_csv))) == 12
    rc, out, err = run(capsys, "calibrate", run_csv, "--method", "li2021", "-o", cal_json)
    assert verdict_of(rc, cal_json)["passed"], out + err  # the seeded typical probe's twelve positions: a pass
    save, plots = tmp_path / "ren.json", tmp_path / "plots"
    rc, out, err = run(capsys, "accept", "--port", emu.path, "--bench", bench_of(emu), "--cal", cal_json,
                       "--grid", "ren2014", "--circles", "-o", save, "--plot", plots, "--quiet")
    r = AcceptResult.load(str(save))
    assert rc == (0 if r.passed else 1) and r.passed, (rc, r.reasons, err)  # li2021's fit meets Ren's grid
    assert r.download is not None and r.before.startswith("as found: identity")
    assert r.after.startswith("li2021 from the file")
    assert len(r.points) == 64 and not r.survey_mismatches and len(r.circles) == 36
    assert "Ren 2014 Table 1 layout" in out and "Ren 2014 Table 2 layout" in out
    # negative tilts: the turntable is at (|t|, A + 180, T + 180), the table reads them back as signed tilts
    neg = [p for p in r.points if p["set_inc"] < 0]
    assert len(neg) == 32 and all(p["pose"][0] == -p["set_inc"] for p in neg)
    assert max(abs(p["after"]["inc_err"]) for p in neg) < 0.1
    assert r.stats["after"]["azi_rms_deg"] < r.stats["before"]["azi_rms_deg"] / 3
    for name in ("errors_ren2014.png", "circles.png"):
        assert (plots / name).stat().st_size > 20000
    rc, out, _ = run(capsys, "plot", "--run", run_csv, "--cal", cal_json, "--accept", save, "-o", tmp_path / "p2")
    assert rc == 0 and (tmp_path / "p2" / "fluxgate_sphere.png").stat().st_size > 20000
    assert (tmp_path / "p2" / "errors_ren2014.png").exists()


def test_continuous_rotation_fits_guo2009(emu, capsys, tmp_path):
    run_csv, cal_json = tmp_path / "cont.csv", tmp_path / "cal.json"
    rc, out, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench_of(emu), "--procedure",
                       "continuous", "--step", "15", "-o", run_csv, "--quiet")
    assert rc == 0, err
    ds = dataset.read_raw(str(run_csv))
    assert len(ds) == 48
    assert set(np.round(ds.columns["inc_deg"], 6)) == {30.0, 120.0} and set(ds.columns["azi_deg"]) == {2.0}
    assert np.all(np.diff(ds.columns["t_s"]) > 0)
    assert np.allclose(ds.columns["tf_deg"][:24], np.arange(0, 360, 15))
    rc, out, err = run(capsys, "calibrate", run_csv, "--method", "guo2009", "-o", cal_json)
    assert verdict_of(rc, cal_json)["passed"], out + err  # 48 rotation readings of the seeded probe: a pass
    azi_id, inc_id = grid_errors(None)
    azi, inc = grid_errors(Calibration.load(str(cal_json)))
    assert azi < azi_id / 3 and inc < inc_id / 3


class PersonAtTable:
    """Stands in for the operator: reads the instruction, sets the emulated
    turntable (over the control channel) to what it says, presses Enter."""

    def __init__(self, ctl, steps):
        self.ctl, self.steps, self.i = ctl, steps, 0
        self.said = []

    def say(self, m):
        self.said.append(m)

    def readline(self):
        st = self.steps[self.i]
        assert f"set inclination {st.inc:.1f} deg" in self.said[-1]
        self.ctl.call("move", inc=st.inc, azi=st.azi, tf=st.tf)
        self.i += 1
        return "\n"


def test_operator_mode_guides_position_by_position(emu, tmp_path):
    ctl = ControlClient(port=emu.control_port)
    steps = acq.procedure_steps("twelve-position")
    person = PersonAtTable(ctl, steps)
    table = ManualTurntable(stdin=person, say=person.say)
    out = tmp_path / "run.csv"
    with ProbeLink(emu.path, timeout=2.0) as link:
        r = acq.acquire(link, "twelve-position", str(out), table, world={"field_nT": 50000, "dip_deg": 60},
                        quiet=True)
    ctl.close()
    assert r.rows == 12 and person.i == 12
    # the instructions say where each body axis points (Li 2021 Table 1, position 1: X down, Y west, Z north)
    assert "[1/12] Li 2021 Table 1 position 1" in person.said[0] and "X down, Y west, Z north" in person.said[0]
    assert "X north, Y east, Z down" in person.said[8]  # position 9
    ds = dataset.read_raw(str(out))
    assert ds.meta["source"].startswith("inclino acquire twelve-position (operator")
    assert ds.meta["dip_deg"] == 60.0
    g, _ = ref.body_vectors(ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"], 50000, 60)
    assert np.abs(ds.acc - g).max() < 0.01


class TurningHand:
    """Wraps the real link: an operator turning the toolface by hand, 9 deg
    further before every reading (the emulated table moved over the control
    channel); readline sets the rotation's start as instructed."""

    def __init__(self, link, ctl):
        self.link, self.ctl, self.timeout = link, ctl, link.timeout
        self.pose, self.said, self.tfs = None, [], []

    def __getattr__(self, name):
        return getattr(self.link, name)

    def say(self, m):
        self.said.append(m)

    def readline(self):
        m = re.search(r"set inclination ([0-9.]+) deg, azimuth ([0-9.]+) deg, toolface 0", self.said[-1])
        self.pose = [float(m.group(1)), float(m.group(2)), 0.0]
        self.ctl.call("move", inc=self.pose[0], azi=self.pose[1], tf=0.0)
        return "\n"

    def request(self, cmd, payload=b"", timeout=None):
        if cmd == "SURVEY_RAW" and self.pose is not None:
            self.pose[2] = (self.pose[2] + 9.0) % 360.0
            self.ctl.call("move", inc=self.pose[0], azi=self.pose[1], tf=self.pose[2])
            self.tfs.append(self.pose[2])
        return self.link.request(cmd, payload, timeout)


def test_operator_turns_the_toolface_by_hand(emu, capsys, tmp_path):
    ctl = ControlClient(port=emu.control_port)
    out = tmp_path / "cont.csv"
    with ProbeLink(emu.path, timeout=2.0) as link:
        hand = TurningHand(link, ctl)
        r = acq.acquire(hand, "continuous", str(out), ManualTurntable(stdin=hand, say=hand.say),
                        world={"field_nT": 50000, "dip_deg": 60}, quiet=True)
    ctl.close()
    assert "turn the toolface slowly" in hand.said[0] and "inclination 120" in hand.said[1]
    ds = dataset.read_raw(str(out))
    assert r.rows == len(ds) >= 2 * 41 and set(np.round(ds.columns["inc_deg"], 6)) == {30.0, 120.0}
    # each row's toolface is the probe's own (uncalibrated) gravity toolface: within Guo's +-1 deg of
    # the table's (0.52 deg at I = 30 deg on the typical probe)
    assert len(hand.tfs) == len(ds)
    assert np.abs(ref.angle_diff(ds.columns["tf_deg"], hand.tfs)).max() < 1.0
    g, _ = ref.body_vectors(ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"], 50000, 60)
    assert np.abs(ds.acc - g).max() < 0.01
    rc, _, err = run(capsys, "calibrate", out, "--method", "guo2009", "-o", tmp_path / "cal.json")
    assert verdict_of(rc, tmp_path / "cal.json")["passed"], err  # the hand-turned rotations fit as well
    azi_id, _ = grid_errors(None)
    assert grid_errors(Calibration.load(str(tmp_path / "cal.json")))[0] < azi_id / 3


def test_operator_instructions_and_quit(emu, tmp_path):
    said = []
    table = ManualTurntable(stdin=io.StringIO("q\n"))
    table.say = said.append
    st = acq.procedure_steps("twelve-position")[0]
    with pytest.raises(KeyboardInterrupt):
        table.move(st, 1, 12)
    assert "Li 2021 Table 1 position 1" in said[0] and "X down, Y west, Z north" in said[0]
    # quitting mid-run leaves no RUN.csv
    out = tmp_path / "run.csv"
    with ProbeLink(emu.path, timeout=2.0) as link:
        with pytest.raises(KeyboardInterrupt):
            acq.acquire(link, "twelve-position", str(out), ManualTurntable(stdin=io.StringIO("\n\nq\n")), quiet=True)
    assert not out.exists()


class SwingingTable:
    """Wraps the real link: before each of the first `swings` requests the
    emulated turntable is moved to alternate +-0.5 deg about the pose (a probe
    still swinging), then left at rest."""

    def __init__(self, link, ctl, pose, swings):
        self.link, self.ctl, self.pose, self.swings, self.n = link, ctl, pose, swings, 0
        self.timeout = link.timeout

    def request(self, cmd, payload=b"", timeout=None):
        inc, azi, tf = self.pose
        if self.n < self.swings:
            inc += 0.5 if self.n % 2 else -0.5
        self.ctl.call("move", inc=inc, azi=azi, tf=tf)
        self.n += 1
        return self.link.request(cmd, payload, timeout)


def test_stability_check_waits_for_the_probe_to_settle(emu):
    ctl = ControlClient(port=emu.control_port)
    waits = []
    with ProbeLink(emu.path, timeout=2.0) as link:
        swinging = SwingingTable(link, ctl, (40.0, 100.0, 20.0), swings=6)
        win = readings.read_stable(swinging, readings.Tolerance(), max_reads=None, waiting=lambda *a: waits.append(a))
        rest = [readings.read_once(link) for _ in range(3)]
    ctl.close()
    # windows holding a swing reading were refused (0.5 deg at I = 40 deg is ~13 mg), the first
    # window after the swing stopped was taken: reads 7, 8, 9
    assert len(waits) == 6 and all(w[0] > 5.0 for w in waits) and swinging.n == 9
    assert len(win) == 3 and readings.Tolerance().agrees(win + rest)
    with pytest.raises(readings.Unsettled):
        with ProbeLink(emu.path, timeout=2.0) as link:
            readings.read_stable(SwingingTable(link, ControlClient(port=emu.control_port), (40.0, 100.0, 20.0), 99),
                            readings.Tolerance(), max_reads=8)


def test_bench_gives_up_when_the_readings_never_agree(emu, capsys, tmp_path):
    out = tmp_path / "run.csv"
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench_of(emu), "--procedure",
                     "twelve-position", "-o", out, "--tol-acc-mg", "0.001", "--max-reads", "5", "--quiet")
    assert rc == 4 and "did not settle" in err and err.count("\n") == 1
    assert not out.exists()


def test_bad_input(emu, capsys, tmp_path):
    out = tmp_path / "run.csv"
    rc, _, err = run(capsys, "acquire", "--port", tmp_path / "no-such-port", "--procedure", "twelve-position",
                     "-o", out)
    assert rc == 4 and "cannot open port" in err and err.count("\n") == 1 and not out.exists()
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--procedure", "spiral", "-o", out)
    assert rc == 2 and err.count("\n") == 1 and err.startswith("inclino: error: acquire: argument --procedure")
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--procedure", "twelve-position", "-o", out,
                     "--average", "0")
    assert rc == 2 and "--average" in err
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", "127.0.0.1:1", "--procedure",
                     "twelve-position", "-o", out)
    assert rc == 4 and "control channel" in err and err.count("\n") == 1
    rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", "nonsense", "--procedure",
                     "twelve-position", "-o", out)
    assert rc == 2 and "HOST:PORT" in err
    # grids the turntable cannot reach are refused before the port is opened (a bogus port: still exit 2)
    for argv in (["--inclinations", "5,200"], ["--grid", "ren2014", "--inclinations=-200,30"],
                 ["--inclinations", "0,0.2"], ["--azimuths", "x"]):
        rc, _, err = run(capsys, "accept", "--port", tmp_path / "no-such-port", *argv)
        assert rc == 2 and err.count("\n") == 1, (argv, err)
    with pytest.raises(Exception):
        grid_points("li2021", inclinations=[181.0])
    rc, _, err = run(capsys, "accept", "--port", tmp_path / "no-such-port")
    assert rc == 4 and "cannot open port" in err
    rc, _, err = run(capsys, "plot", "-o", tmp_path / "p")
    assert rc == 2 and "nothing to plot" in err
    assert not out.exists()


def test_accept_without_calibration_fails_its_verdict(emu, capsys):
    rc, out, _ = run(capsys, "accept", "--port", emu.path, "--bench", bench_of(emu), "--inclinations", "5,60",
                     "--azimuths", "0,180", "--json", "--quiet")
    d = json.loads(out)
    assert rc == 1 and not d["passed"] and d["after"].startswith("as found: identity")
    assert any("azimuth RMS" in r or "inclination RMS" in r for r in d["reasons"])
    assert d["stats"]["before"] == d["stats"]["after"]


@pytest.mark.heavy
@pytest.mark.parametrize("passed", [True, False])
def test_bench_calibration_cli(monkeypatch, capsys, small_calibration_bench, passed):
    """`inclino bench calibration` is a shell over bench_calibration (the
    library's result, computed once for the suite at its smallest size and
    checked in test_calib_cli): the JSON printed is the result's, the text
    names every method, the exit status follows the targets."""
    import dataclasses

    from inclino.benchmarks import calibration as bench

    r = dataclasses.replace(small_calibration_bench, passed=passed)
    monkeypatch.setattr(bench, "bench_calibration", lambda: r)
    rc, out, _ = run(capsys, "bench", "calibration", "--json")
    d = json.loads(out)
    assert rc == (0 if passed else 1) and d == json.loads(r.to_json())
    assert d["runs"] == 1 and {"joint", "ren2014", "li2021", "guo2009"} <= set(d["methods"])
    assert d["cramer_rao"]["azi_rms_deg"] > 0 and "ratio_to_cramer_rao" in d["met"]
    rc, out, _ = run(capsys, "bench", "calibration")
    assert rc == (0 if passed else 1)
    for k in ("joint", "ren2014", "li2021", "guo2009", "Cramer-Rao floor"):
        assert k in out, out
    assert ("targets met" in out) == passed


@pytest.mark.parametrize("before, after, says", [
    (0.8, 0.05, "16.0x smaller"), (0.25, 0.5, "2.0x larger"), (0.5, 0.51, "about the same"),
    (0.5, 0.5, "about the same"), (None, 0.5, "-"), (0.3, 0.0, "down to 0"),
])
def test_accept_words_a_change_the_right_way_round(before, after, says):
    """An error that grew is `larger`, never `0.5x smaller`."""
    from inclino.procedures.accept import change

    assert change(before, after) == says
