"""End to end through a real pseudo-terminal: the emulated probe runs its
firmware (C through cffi) behind `inclino emulate`; the host opens the port
with pyserial, moves the turntable over the control channel and reads
surveys."""
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from inclino.engines import reference as ref
from inclino.link.serial_link import ProbeError, ProbeLink
from inclino_emu.control import ControlClient
from inclino_emu.runner import Emulator


def _diff(a, b):
    return abs(float(ref.angle_diff(a, b)))


@pytest.fixture
def emu():
    e = Emulator("ideal", control_port=0).start()
    yield e
    e.stop()


def test_surveys_follow_the_turntable(emu):
    ctl = ControlClient(port=emu.control_port)
    sc = emu.probe.scenario
    F, dip = sc.world.earth.field_nT, sc.world.earth.dip_deg
    with ProbeLink(emu.path, timeout=2.0) as link:
        ident = link.identify()
        assert ident.product == "INCLINO-PROBE" and ident.cal_slot == 0xFF
        for inc, azi, tf in [(0.0, 0.0, 0.0), (5.0, 45.0, 30.0), (30.0, 120.0, 200.0), (90.0, 270.0, 10.0),
                             (135.0, 330.0, 95.0)]:
            assert ctl.call("move", inc=inc, azi=azi, tf=tf)["ok"] is True
            truth = ctl.call("truth")
            assert truth["pose"] == [inc, azi, tf]
            s = link.survey().to_units()
            # ideal probe: the scenario predicts the pose up to the sensors' quantisation
            g, b = ref.body_vectors(inc, azi, tf, F, dip)
            q = ref.attitude(ref.quantise_acc(g) * ref.ACC_LSB_G, ref.quantise_mag(b) * 1.0)
            assert _diff(s["inc_deg"], inc) <= _diff(float(q["inc"]), inc) + 0.005
            assert abs(s["dip_deg"] - dip) < 0.02 and abs(s["bt_nT"] - F) < 2.0
            if inc >= 1.0:
                assert _diff(s["azi_deg"], azi) <= _diff(float(q["azi"]), azi) + 0.01
                assert _diff(s["tf_deg"], tf) <= _diff(float(q["gtf"]), tf) + 0.01
                assert not s["flags"] & 1
            else:
                assert s["flags"] & 1  # near vertical
        assert link.stats.retries == 0
    ctl.close()


def test_text_console_and_garbage(emu):
    with serial.Serial(emu.path, 115200, timeout=1.0) as s:
        s.write(b"\x00\xff\x13garbage\x7f\r")
        assert s.readline() == b"? HELP lists the commands\r\n"
        s.write(b"id\r")
        assert re.match(rb"INCLINO-PROBE fw 1\.0 serial \d+ cal none\r\n", s.readline())
        s.write(b"SV\r")
        line = s.readline().decode()
        assert re.match(r"INC \d+\.\d{4} AZI \d+\.\d{4} TF \d+\.\d{4} GT 1\.\d{4} BT \d+\.\d DIP -?\d+\.\d{3} QC ",
                        line), line
    # and the framed protocol still works after the noise
    with ProbeLink(emu.path, timeout=2.0) as link:
        assert link.identify().product == "INCLINO-PROBE"


def test_stream_reset_and_link_faults(emu):
    ctl = ControlClient(port=emu.control_port)
    ctl.call("move", inc=20, azi=60, tf=30)
    with ProbeLink(emu.path, timeout=1.0, retries=8) as link:
        recs = list(link.stream(period_ms=50, count=5))
        assert len(recs) == 5 and all(abs(r.to_units()["inc_deg"] - 20) < 0.02 for r in recs)
        link.reset()
        assert link.identify().product == "INCLINO-PROBE"
        assert ctl.call("status")["restarts"] == 1
        # a noisy line: bit errors at 1e-3 and dropped bytes; every request still completes
        ctl.call("faults", bit_error_rate=1e-3, drop_rate=2e-3, seed=5)
        for _ in range(10):
            assert abs(link.survey().to_units()["azi_deg"] - 60) < 0.05
        counts = ctl.call("faults")["counts"]
        assert counts["bit_errors"] + counts["dropped"] > 0
        # a disconnect: a clear error, then recovery when the line returns
        ctl.call("faults", bit_error_rate=0.0, drop_rate=0.0, disconnected=True)
        link.retries = 1
        with pytest.raises(ProbeError, match="no answer from the probe"):
            link.identify()
        ctl.call("faults", disconnected=False)
        link.retries = 4
        assert link.identify().product == "INCLINO-PROBE"
    ctl.close()


def test_inclino_emulate_cli_runs_and_stops(tmp_path):
    lp = str(tmp_path / "probe")
    # SIGINT back to its default in the child: a suite started in the background by a shell without job
    # control inherits SIGINT ignored, and Python then never raises KeyboardInterrupt (as a person's
    # Ctrl-C in a terminal would); that, not the emulator, was what kept it running after the signal
    proc = subprocess.Popen([sys.executable, "-m", "inclino", "emulate", "--scenario", "ideal", "--link", lp],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        line = proc.stdout.readline()
        assert line.startswith("inclino emulator: probe on /dev/pts/"), line
        ctl_line = proc.stdout.readline()
        port = int(re.search(r"127\.0\.0\.1:(\d+)", ctl_line).group(1))
        # the next commands to try, printed before the probe starts (read here: communicate() below reads the
        # pipe itself and would miss lines this reader has already buffered)
        said = [proc.stdout.readline() for _ in range(8)]
        with ProbeLink(lp, timeout=2.0) as link:
            assert link.identify().product == "INCLINO-PROBE"
        c = ControlClient(port=port)
        assert c.call("status")["ok"] is True
        c.close()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            pytest.fail(f"inclino emulate still running 30 s after SIGINT; its output: {out!r} {err!r}")
    assert proc.returncode == 0, err
    assert "stopped" in out and "Traceback" not in err
    assert not os.path.exists(lp)
    # the next commands to try: the technician's loop on this probe, each one a command line inclino takes
    from inclino.cli import build_parser

    assert said[0].startswith("next, in another terminal")
    tries = [x.strip().split() for x in said if x.startswith("  inclino ")]
    assert [t[1] for t in tries] == ["identify", "survey", "acquire", "calibrate", "download", "verify", "accept"]
    for t in tries:
        a = build_parser().parse_args(t[1:])
        assert getattr(a, "port", lp) == lp and getattr(a, "bench", None) in (None, f"127.0.0.1:{port}")


def test_wrong_port_is_one_clear_error(tmp_path):
    with pytest.raises(ProbeError, match="cannot open port"):
        ProbeLink(str(tmp_path / "nothing-here"))
