"""The link against hostile devices and a shared port (docs/cli.md, "The
port"): an answer with a valid CRC and a payload of the wrong length, a
second command on a busy port, a shell's terminal given as the port, a
device that is not a probe (its settings restored), `inclino ports`,
$INCLINO_PORT, and the logging commands keeping what they took when the
link fails or Ctrl-C stops them."""
import json
import os
import subprocess
import sys
import time

import pytest

from fakeprobe import FakeDevice, answer_with, termios_state
from inclino import cli
from inclino.formats.calfile import Calibration
from inclino.link.serial_link import ProbeError, ProbeLink
from inclino_emu.runner import Emulator


@pytest.fixture(scope="module")
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def one_error(err, *needles):
    assert err.startswith("inclino: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


# ------------------------------------------------------------ a valid frame of the wrong length
def _commands(tmp_path, port, emu):
    cal = tmp_path / "cal.json"
    Calibration(probe_serial="1001").save(str(cal))
    return {
        "identify": (["identify", "--port", port], "IDENTIFY"),
        "survey": (["survey", "--port", port], "IDENTIFY"),
        "survey --stream": (["survey", "--port", port, "--stream", "--period-ms", "10", "--count", "3"], "IDENTIFY"),
        "download": (["download", "--port", port, "--cal", str(cal)], "CAL_WRITE"),
        "verify": (["verify", "--port", port, "--cal", str(cal)], "IDENTIFY"),
        "reffield --port": (["reffield", "--declination", "2", "--dip", "60", "--field", "50000", "--port", port],
                            "QCREF_WRITE"),
        "acquire": (["acquire", "--port", port, "--bench", f"127.0.0.1:{emu.control_port}", "--procedure",
                     "twelve-position", "-o", str(tmp_path / "run.csv")], "IDENTIFY"),
    }


@pytest.mark.parametrize("command", ["identify", "survey", "survey --stream", "download", "verify",
                                     "reffield --port", "acquire"])
def test_wrong_length_answer_is_a_link_error_naming_command_and_length(emu, tmp_path, capsys, command):
    with FakeDevice(answer_with(bytes(200))) as dev:
        argv, name = _commands(tmp_path, dev.path, emu)[command]
        rc, out, err = run(capsys, *argv)
    assert rc == 4, err
    one_error(err, name, "200 bytes")
    assert not (tmp_path / "run.csv").exists()


def test_wrong_length_stream_frame(tmp_path, capsys):
    """STREAM accepted, then a streamed survey frame of the wrong length."""
    from inclino.link import protocol

    ident = protocol.Identity("INCLINO-PROBE", (1, 0, 0), 1, 1001, 0xFF, 0, 0, 0, 0).pack()

    def answer(f):
        if f.cmd == protocol.CMD["IDENTIFY"]:
            return protocol.encode_frame(f.seq, f.cmd | 0x80, ident)
        if f.cmd == protocol.CMD["STREAM"]:
            return protocol.encode_frame(f.seq, f.cmd | 0x80) + protocol.encode_frame(0, protocol.STREAM_FRAME,
                                                                                      bytes(7))
        return protocol.encode_frame(f.seq, f.cmd | 0x80, bytes(2))
    with FakeDevice(answer) as dev:
        rc, out, err = run(capsys, "survey", "--port", dev.path, "--stream", "--period-ms", "10", "--count", "2")
    assert rc == 4
    one_error(err, "streamed survey", "7 bytes")


# ------------------------------------------------------------ the port
def test_busy_port_is_named_busy(emu, capsys):
    with ProbeLink(emu.path, timeout=2.0) as first:
        first.identify()
        rc, out, err = run(capsys, "identify", "--port", emu.path)
        assert rc == 4
        one_error(err, "busy")
        first.identify()  # the first command's link was not disturbed


def test_two_downloads_at_once_the_second_is_refused(emu, tmp_path, capsys):
    from inclino.model.scenario import load_scenario

    scn = load_scenario("typical")
    cal = tmp_path / "cal.json"
    Calibration(probe_serial=str(scn.serial)).save(str(cal))
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    # the first download holds the port: a process that keeps a link open while the second runs
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\nfrom inclino.link.serial_link import ProbeLink\n"
        f"l = ProbeLink({emu.path!r}, timeout=2.0)\nprint('open', flush=True)\ntime.sleep(30)\n")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert holder.stdout.readline().strip() == "open"
        rc, out, err = run(capsys, "download", "--port", emu.path, "--cal", cal)
        assert rc == 4
        one_error(err, "busy")
    finally:
        holder.kill()
        holder.wait()


def test_a_sessions_terminal_is_refused_before_a_byte_is_written(capsys):
    import fcntl
    import pty
    import select
    import termios

    master, slave = pty.openpty()
    path = os.ttyname(slave)
    # a process whose controlling terminal is this pty (a shell's window)
    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"], stdin=slave, stdout=slave,
                         stderr=slave, start_new_session=True,
                         preexec_fn=lambda: fcntl.ioctl(0, termios.TIOCSCTTY, 0))
    try:
        time.sleep(0.3)
        before = termios_state(path)
        rc, out, err = run(capsys, "identify", "--port", path)
        assert rc == 4
        one_error(err, "terminal of a running session", "nothing was written")
        assert termios_state(path) == before
        r, _, _ = select.select([master], [], [], 0.2)
        assert not r  # no byte reached the terminal
    finally:
        p.kill()
        p.wait()
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("device", ["silent", "modem"])
def test_a_device_that_is_no_probe_gets_its_settings_back(capsys, device):
    answer = (lambda f: None) if device == "silent" else (lambda f: b"\r\nOK\r\n")
    with FakeDevice(answer) as dev:
        before = termios_state(dev.path)
        rc, out, err = run(capsys, "identify", "--port", dev.path, "--timeout", "0.1")
        assert rc == 4
        one_error(err, "not an inclino probe" if device == "modem" else "no answer")
        assert termios_state(dev.path) == before


def test_no_answer_names_another_process_holding_the_port(capsys):
    with FakeDevice(lambda f: None) as dev:
        holder = subprocess.Popen([sys.executable, "-c", f"f = open({dev.path!r}, 'rb'); import time; "
                                                         "print('open', flush=True); time.sleep(30)"],
                                  stdout=subprocess.PIPE, text=True)
        try:
            assert holder.stdout.readline().strip() == "open"
            rc, out, err = run(capsys, "identify", "--port", dev.path, "--timeout", "0.1")
        finally:
            holder.kill()
            holder.wait()
    assert rc == 4
    one_error(err, f"pid {holder.pid}")


def test_ports_lists_the_emulated_probe_and_identifies_it(emu, capsys):
    rc, out, err = run(capsys, "ports", "--json")
    d = json.loads(out)
    assert rc == 0 and emu.path in [p["device"] for p in d["ports"]]
    rc, out, err = run(capsys, "ports", "--identify", "--json", emu.path)
    (p,) = json.loads(out)["ports"]
    assert rc == 0 and p["probe"]["product"] == "INCLINO-PROBE" and p["held_by"] == []


def test_inclino_port_gives_the_default(emu, capsys, monkeypatch):
    monkeypatch.setenv("INCLINO_PORT", emu.path)
    rc, out, err = run(capsys, "identify", "--json")
    assert rc == 0 and json.loads(out)["product"] == "INCLINO-PROBE"
    monkeypatch.delenv("INCLINO_PORT")
    rc, out, err = run(capsys, "identify")
    assert rc == 2
    one_error(err, "--port")


# ------------------------------------------------------------ logging commands keep what they took
@pytest.mark.parametrize("how", ["ctrl-c", "link"])
def test_survey_las_keeps_the_surveys_taken(emu, tmp_path, capsys, monkeypatch, how):
    import lasio

    real = ProbeLink.survey
    calls = {"n": 0}

    def survey(self):
        calls["n"] += 1
        if calls["n"] == 13:
            if how == "ctrl-c":
                raise KeyboardInterrupt
            raise ProbeError("no answer from the probe (test)")
        return real(self)

    monkeypatch.setattr(ProbeLink, "survey", survey)
    las = tmp_path / "run.las"
    rc, out, err = run(capsys, "survey", "--port", emu.path, "--count", "20", "--csv", "--las", las)
    assert rc == (130 if how == "ctrl-c" else 4)
    one_error(err, "12 readings", str(las))
    printed = [ln for ln in out.strip().splitlines() if not ln.startswith("#")]
    assert len(printed) == 13  # the header and the 12 surveys printed stay printed
    assert len(lasio.read(str(las)).index) == 12


def test_acquire_keeps_its_rows_on_a_link_failure(emu, tmp_path, capsys, monkeypatch):
    from inclino.link import operations

    real = operations.survey_with_raw
    calls = {"n": 0}

    def fail_later(link):
        calls["n"] += 1
        if calls["n"] > 12:
            raise ProbeError("no answer from the probe (test)")
        return real(link)

    import inclino.procedures.readings as readings
    monkeypatch.setattr(readings, "survey_with_raw", fail_later, raising=False)
    monkeypatch.setattr(operations, "survey_with_raw", fail_later)
    out = tmp_path / "run.csv"
    rc, o, err = run(capsys, "acquire", "--port", emu.path, "--bench", f"127.0.0.1:{emu.control_port}",
                     "--procedure", "twelve-position", "-o", out, "--quiet")
    assert rc == 4
    one_error(err, "rows kept in", "run.csv.part")
    rows = [ln for ln in (tmp_path / "run.csv.part").read_text().splitlines() if not ln.startswith("#")]
    assert len(rows) >= 2 and not out.exists()
