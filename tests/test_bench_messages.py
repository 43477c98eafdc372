"""What the link's errors say when a technician's bench goes wrong in the
middle of a command (the bench review, /tmp/bench/REPORT.md): a probe that
answered and then went silent is not a wrong port, and the probe's own text
console answering a request whose frame start the line lost is the probe, on
a noisy line, not another device."""
import pytest

from inclino.link.serial_link import ProbeError, ProbeLink
from inclino_emu.runner import Emulator


@pytest.fixture
def emu():   # one per test: the firmware has one owner per process, and other modules hold theirs by module
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def test_a_probe_that_stops_answering_is_not_called_the_wrong_port(emu, ctl):
    with ProbeLink(emu.path, timeout=0.2, retries=1) as link:
        link.identify()                            # it answers: port and baud rate are right
        ctl.call("faults", disconnected=True)     # the cable is pulled
        with pytest.raises(ProbeError) as ei:
            link.request("SURVEY")
    msg = str(ei.value)
    assert "no answer from the probe" in msg and "stopped answering" in msg and "answered earlier" in msg and "check the cable" in msg
    assert "wrong port" not in msg and "\n" not in msg


def test_the_probes_console_answering_a_frame_without_its_start_is_a_noisy_link(emu):
    with ProbeLink(emu.path, timeout=0.2, retries=1) as link:
        write = link._write
        link._write = lambda data: write(data[1:] if data[:1] == b"\xa5" else data)  # the line drops 0xA5
        with pytest.raises(ProbeError) as ei:
            link.request("IDENTIFY", b"CAL\r")    # the rest reaches the console as a text line
    msg = str(ei.value)
    assert "the link is noisy" in msg and "not an inclino probe" not in msg, msg


# ---- a damaged S-record file: the line, what is wrong with it in the file's terms, and the fix -----
def _image(tmp_path):
    from bootimg import random_chunks, write_srec
    return open(write_srec(tmp_path / "app.s19", random_chunks(2, [(0x7C0000, 600)]))).read()


@pytest.mark.parametrize("damage, cause", [
    (lambda t: t[:len(t) // 2], "hex digits follow its count byte"),                 # cut mid-record
    (lambda t: t[:200] + "G" + t[201:], "character 'G' at column"),                   # a bit flipped a digit
    (lambda t: "".join(t.splitlines(keepends=True)[:-1]), "a file cut short has lost it"),   # cut at a line end
])
def test_a_damaged_image_file_says_what_and_what_to_do(tmp_path, damage, cause):
    from inclino.boot.image import check_entry, load_image
    from inclino.errors import DataError
    (tmp_path / "bad.s19").write_text(damage(_image(tmp_path)))
    with pytest.raises(DataError) as ei:
        check_entry(load_image(str(tmp_path / "bad.s19")))
    msg = str(ei.value)
    assert cause in msg and "get the image again" in msg and "nothing was erased" in msg, msg
    assert "fromhex" not in msg and "\n" not in msg


# ---- acquire: an option of another procedure is refused, not ignored ------------------------
@pytest.mark.parametrize("procedure, extra, opt", [
    ("twelve-position", ["--temperatures", "-5,25"], "--temperatures"),   # still one run at 25 degC
    ("twelve-position", ["--d1", "50"], "--d1"),
    ("continuous", ["--points", "10"], "--points"),
    ("multi-position", ["--target-azi-deg", "0.05"], "--target-azi-deg"),
    ("adaptive", ["--ramp-rate", "2"], "--ramp-rate"),
    ("temperature", ["--step", "5"], "--step"),
])
def test_acquire_refuses_an_option_its_procedure_ignores(tmp_path, capsys, procedure, extra, opt):
    from inclino import cli
    rc = cli.main(["acquire", "--port", str(tmp_path / "no-port"), "--procedure", procedure,
                   "-o", str(tmp_path / "run.csv"), *extra])
    err = capsys.readouterr().err
    assert rc == 2 and f"{opt} is an option of --procedure" in err and err.count("\n") == 1, err


def test_acquire_takes_its_own_options_and_defaults_given_again(tmp_path, capsys):
    from inclino import cli
    for procedure, extra in (("multi-position", ["--points", "10"]), ("continuous", ["--d1", "40", "--step", "15"]),
                             ("twelve-position", ["--points", "36", "--temperatures", "-5,25,55"])):
        rc = cli.main(["acquire", "--port", str(tmp_path / "no-port"), "--procedure", procedure,
                       "-o", str(tmp_path / "run.csv"), *extra])
        err = capsys.readouterr().err
        assert rc == 4 and "cannot open port" in err, (procedure, err)   # past the option checks


@pytest.mark.parametrize("fmt, said", [([], "a table; --csv"), (["--csv"], "as CSV with --csv"),
                                        (["--json"], "as JSON lines with --json")])
def test_survey_to_stdout_twice_names_the_format_given(tmp_path, capsys, fmt, said):
    from inclino import cli
    rc = cli.main(["survey", "--port", str(tmp_path / "no-port"), "-o", "-", *fmt])
    err = capsys.readouterr().err
    assert rc == 2 and said in err and err.count("\n") == 1, err
    assert fmt != ["--json"] or "--csv" not in err


# ---- accept --cal cut short after its download says the file's calibration is now active ---------
@pytest.mark.parametrize("stop, exc", [(KeyboardInterrupt, KeyboardInterrupt), ("unreachable", Exception)])
def test_accept_cut_short_after_its_download_says_the_calibration_changed(emu, tmp_path, stop, exc):
    from inclino.errors import InclinoError
    from inclino.procedures import accept as acc
    from inclino.procedures.turntable_emulated import EmulatedTurntable
    from test_probe_cli import inverse_cal

    class Stops(EmulatedTurntable):
        def move(self, step, index, total):
            if index == 3:
                if stop is KeyboardInterrupt:
                    raise KeyboardInterrupt
                raise InclinoError("the bench's control channel is unreachable")
            super().move(step, index, total)

    table = Stops(f"127.0.0.1:{emu.control_port}")
    try:
        with ProbeLink(emu.path, timeout=2.0) as link:
            seq0 = link.identify().cal_sequence
            with pytest.raises(exc) as ei:
                acc.accept(link, table, cal=inverse_cal(emu.probe.scenario), quiet=True)
            seq = link.identify().cal_sequence
    finally:
        table.close()
    assert seq == seq0 + 1                                        # the download took place
    assert f"the file's calibration stays active on the probe" in str(ei.value)
    assert f"sequence {seq}" in str(ei.value)


# ---- a port that echoes (a loopback plug, a terminal echo) is named as such, not a noisy probe ----
@pytest.fixture
def echo_port():
    import os
    import threading
    import tty
    master, slave = os.openpty()
    tty.setraw(slave)
    stop = threading.Event()

    def echo():
        import select
        while not stop.is_set():
            if select.select([master], [], [], 0.01)[0]:
                try:
                    os.write(master, os.read(master, 4096))
                except OSError:
                    pass
    t = threading.Thread(target=echo, daemon=True)
    t.start()
    yield os.ttyname(slave)
    stop.set()
    t.join()
    os.close(master)
    os.close(slave)


def test_a_port_that_echoes_the_requests_is_a_loopback_not_a_noisy_probe(echo_port):
    from inclino.link.serial_link import B_IDENTIFY
    with ProbeLink(echo_port, timeout=0.1, retries=1) as link:
        for ask in (link.identify, lambda: link.request(B_IDENTIFY)):
            with pytest.raises(ProbeError) as ei:
                ask()
            msg = str(ei.value)
            assert "sends back every request" in msg and "loopback" in msg and "noisy" not in msg, msg
        assert "B_IDENTIFY" in msg and "0x40" not in msg       # the bootloader's command by its name


# ---- a CAL.json edited by hand with a mirrored axis: the element is named, nothing written ----
def test_download_names_a_mirrored_diagonal_before_writing(emu):
    from inclino.errors import CalibrationError
    from inclino.link import operations as calops
    from test_probe_cli import inverse_cal

    cal = inverse_cal(emu.probe.scenario)
    cal.mag_m = [[-v for v in cal.mag_m[0]], list(cal.mag_m[1]), list(cal.mag_m[2])]   # x axis reversed
    with ProbeLink(emu.path, timeout=1.0) as link:
        seq0 = link.identify().cal_sequence
        with pytest.raises(CalibrationError) as ei:
            calops.download(link, cal)
        assert link.identify().cal_sequence == seq0
    msg = str(ei.value)
    assert "mag_m[0][0] is -" in msg and "mirrored axis" in msg and "nothing written" in msg, msg


def test_a_device_that_goes_away_mid_command_is_said_in_the_benchs_words():
    import os
    master, slave = os.openpty()
    name = os.ttyname(slave)
    link = ProbeLink(name, timeout=0.2, retries=0)
    os.close(master)                       # the emulator stopped / the adapter was unplugged
    os.close(slave)
    try:
        with pytest.raises(ProbeError) as ei:
            link.identify()
    finally:
        link.close()
    msg = str(ei.value)
    assert "the device went away" in msg and "run the command again" in msg, msg
    assert "multiple access" not in msg and "Errno" not in msg


# ---- emulate: a negative seed and a control port in use name the option and the fix --------------
@pytest.mark.parametrize("argv, said", [(["--seed", "-1"], "--seed -1: a seed is an integer >= 0"),
                                        (["--tempco-draw", "-3"], "--tempco-draw -3: a seed is an integer >= 0")])
def test_emulate_names_a_negative_seed(capsys, argv, said):
    from inclino import cli
    rc = cli.main(["emulate", "--unthrottled", *argv])
    err = capsys.readouterr().err
    assert rc == 2 and said in err and err.count("\n") == 1, err


def test_emulate_on_a_control_port_in_use_says_what_to_do(capsys):
    import socket
    from inclino import cli
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    try:
        rc = cli.main(["emulate", "--unthrottled", "--control", str(s.getsockname()[1])])
    finally:
        s.close()
    err = capsys.readouterr().err
    assert rc == 2 and "Address already in use" in err and "0 for any free one" in err and err.count("\n") == 1, err


# ---- download through a power cut at the commit: the retry says the probe restarted ---------------
def test_download_through_a_power_cut_says_the_probe_restarted(emu, ctl):
    from inclino.link import operations as calops
    from test_probe_cli import inverse_cal

    ctl.call("power_cut", n=18, mode="none")      # the 18th flash command is the commit (docs/flash.md)
    with ProbeLink(emu.path, timeout=1.0) as link:
        r = calops.download(link, inverse_cal(emu.probe.scenario, scale=0.998))
    assert r.ok and r.attempts == 2
    assert any("the probe restarted before its activation was done" in e for e in r.events), r.events


# ---- survey -o --append after a run stopped mid-row: the cut row is dropped, not glued onto ----------
def test_survey_append_after_a_row_cut_short(emu, tmp_path, capsys):
    import csv
    from inclino import cli
    log = tmp_path / "run.csv"
    assert cli.main(["survey", "--port", emu.path, "--count", "2", "-o", str(log)]) == 0
    log.write_text(log.read_text()[:-30])                   # killed while writing the second row
    capsys.readouterr()
    assert cli.main(["survey", "--port", emu.path, "--count", "1", "-o", str(log), "--append"]) == 0
    err = capsys.readouterr().err
    assert "last row was cut short" in err and "dropped" in err, err
    rows = list(csv.reader(ln for ln in log.read_text().splitlines() if not ln.startswith("#")))
    assert len(rows) == 3 and {len(r) for r in rows} == {len(rows[0])}     # header, the whole row, the new one


# ---- a run file cut short inside its last row says so, a short row in the middle does not ------------
def test_a_run_file_cut_inside_its_last_row_says_so(tmp_path):
    from inclino.errors import DataError
    from inclino.formats import dataset
    head = "# field_nT=50000\n# dip_deg=60\ninc_deg,azi_deg,tf_deg,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n"
    row = "10,20,30,0.1,0.2,0.97,20000,1000,43000\n"
    (tmp_path / "cut.csv").write_text(head + row * 3 + row[:15])
    with pytest.raises(DataError) as ei:
        dataset.read_raw(str(tmp_path / "cut.csv"))
    assert "cut.csv:7: 5 cells" in str(ei.value) and "the file ends inside this row" in str(ei.value)
    (tmp_path / "mid.csv").write_text(head + row + row[:15] + "\n" + row)
    with pytest.raises(DataError) as ei:
        dataset.read_raw(str(tmp_path / "mid.csv"))
    assert "mid.csv:5: 5 cells" in str(ei.value) and "ends inside" not in str(ei.value)


@pytest.mark.parametrize("argv", [["--max-azi-rms", "-1"], ["--max-inc-rms", "0"], ["--max-azi-rms", "nan"],
                                  ["--max-inc-rms", "inf"]])
def test_accept_refuses_a_limit_no_grid_can_meet(tmp_path, capsys, argv):
    from inclino import cli
    rc = cli.main(["accept", "--port", str(tmp_path / "no-port"), *argv])
    err = capsys.readouterr().err
    assert rc == 2 and f"{argv[0]} " in err and "the verdict's limit" in err and err.count("\n") == 1, err


@pytest.mark.parametrize("value", ["nan", "1e308", "-inf"])
def test_accept_refuses_a_declination_that_is_no_angle(tmp_path, capsys, value):
    """--declination nan ran the whole grid and ended in a TypeError traceback
    (the azimuth RMS was nan, rendered None)."""
    from inclino import cli
    rc = cli.main(["accept", "--port", str(tmp_path / "no-port"), "--declination", value])
    err = capsys.readouterr().err
    assert rc == 2 and "--declination" in err and "Traceback" not in err and err.count("\n") == 1, err


# ---- the stability check: --max-reads below --reads is refused; a probe left at a low --average is named --
def test_max_reads_below_reads_is_refused_before_the_port(tmp_path, capsys):
    from inclino import cli
    for cmd in (["acquire", "--procedure", "twelve-position", "-o", str(tmp_path / "r.csv")], ["accept"]):
        rc = cli.main([cmd[0], "--port", str(tmp_path / "no-port"), *cmd[1:], "--max-reads", "2"])
        err = capsys.readouterr().err
        assert rc == 2 and "--max-reads 2: at least --reads (3)" in err and err.count("\n") == 1, err


def test_unsettled_readings_name_a_probe_left_at_a_low_average(emu):
    from inclino.procedures.readings import Tolerance, Unsettled, read_stable, set_average
    with ProbeLink(emu.path, timeout=1.0) as link:
        set_average(link, 1)
        try:
            with pytest.raises(Unsettled) as ei:
                read_stable(link, Tolerance(acc_mg=1e-6, mag_nT=1e-6), max_reads=4)
        finally:
            set_average(link, 16)
        with pytest.raises(Unsettled) as ok:
            read_stable(link, Tolerance(acc_mg=1e-6, mag_nT=1e-6), max_reads=4)
    assert "the probe averages 1 sample per reading" in str(ei.value) and "--average 16" in str(ei.value)
    assert "averages" not in str(ok.value)                      # at its default: no such note


# ---- calibrate: the options of a fit without poses, given for a run with poses, are said to change nothing --
def test_calibrate_says_pose_free_options_are_not_used_on_a_posed_run(tmp_path, capsys):
    from inclino import cli
    from inclino.benchmarks import calibration as bench
    from inclino.formats.dataset import write_raw
    s = bench.bench_probe(linear=True)
    write_raw(str(tmp_path / "run.csv"), bench.emulated_run(s, bench.calibration_poses(), seed=21))
    assert cli.main(["calibrate", str(tmp_path / "run.csv"), "-o", str(tmp_path / "prior.json")]) == 0
    capsys.readouterr()
    rc = cli.main(["calibrate", str(tmp_path / "run.csv"), "-o", str(tmp_path / "c.json"),
                   "--prior", str(tmp_path / "prior.json"), "--mount-tolerance-deg", "1"])
    err = capsys.readouterr().err
    assert rc == 0 and "--prior, --mount-tolerance-deg not used: the poses of" in err, err
    rc = cli.main(["calibrate", str(tmp_path / "run.csv"), "-o", str(tmp_path / "c.json")])
    assert rc == 0 and "not used" not in capsys.readouterr().err


# ---- download interrupted: the line says what the probe holds -----------------------------------
@pytest.mark.parametrize("at, said, changed", [("write", "nothing activated: the probe keeps its previous", False),
                                               ("read back", "nothing activated", False),
                                               ("confirm", "the activation was sent", True)])
def test_an_interrupted_download_says_what_the_probe_holds(emu, at, said, changed):
    from inclino.link import operations as calops
    from test_probe_cli import inverse_cal

    def cb(stage):
        if stage == at:
            raise KeyboardInterrupt

    with ProbeLink(emu.path, timeout=1.0) as link:
        seq0 = link.identify().cal_sequence
        with pytest.raises(KeyboardInterrupt) as ei:
            calops.download(link, inverse_cal(emu.probe.scenario, scale=0.997), progress=cb)
        seq = link.identify().cal_sequence
    assert said in str(ei.value) and (seq != seq0) == changed
