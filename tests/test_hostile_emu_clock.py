"""The emulator's clock and its control channel under a careless client
(docs/emulator.md): `advance` on the default real-time emulator moves the
probe's clock and chamber without silencing the serial side (a day of
emulated time is not a day of wall time), the probe answers at once after
it, `acquire --procedure temperature` runs against a plain `inclino
emulate`, and idle control clients are closed so that they cannot lock out
the bench."""
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from inclino.link.serial_link import ProbeLink
from inclino_emu.control import MAX_CLIENTS, ControlClient
from inclino_emu.runner import Emulator

BIN = os.path.join(os.path.dirname(sys.executable), "inclino")


@pytest.fixture
def realtime():
    e = Emulator("typical", control_port=0, realtime=True).start()
    yield e
    e.stop()


def test_advance_a_day_on_a_realtime_emulator(realtime):
    c = ControlClient(port=realtime.control_port, timeout=60)
    try:
        t0 = c.call("truth")["t"]
        w0 = time.monotonic()
        a = c.call("advance", s=86400.0)
        assert a["ok"] and a["t"] >= t0 + 86400.0
        assert time.monotonic() - w0 < 30.0  # emulated, not waited for
        w0 = time.monotonic()
        with ProbeLink(realtime.path, timeout=2.0) as link:
            assert link.identify().product == "INCLINO-PROBE"
            s = link.survey()
        assert time.monotonic() - w0 < 5.0  # the probe answers at once, not a day later
        assert s.t_ms / 1000.0 >= t0 + 86400.0  # the probe's own clock moved on
        # the chamber moved with it: a set point 20 K away reached after a soak
        c.call("chamber", setpoint_c=45.0, rate_c_per_min=5.0)
        c.call("advance", s=3 * 3600.0)
        assert abs(c.call("truth")["temp_c"] - 45.0) < 0.5
    finally:
        c.close()


def test_short_advances_do_not_delay_the_answers(realtime):
    c = ControlClient(port=realtime.control_port, timeout=60)
    try:
        with ProbeLink(realtime.path, timeout=2.0) as link:
            for _ in range(3):
                c.call("advance", s=20.0)
                w0 = time.monotonic()
                link.identify()
                assert time.monotonic() - w0 < 2.0
    finally:
        c.close()


def test_the_serial_side_is_served_during_a_long_advance(realtime):
    """Surveys taken while a day is fast-forwarded are answered in the middle
    of it: the probe's clock in their answers lies inside the advance.  A
    day's advance takes a few 20 ms slices of wall time (0.07-0.3 s), so a
    survey falls between two slices only in some tries: up to 100 tries,
    stopping at the first (under load 20 of 20 tries catch one; an idle
    machine's advance is shorter, hence the many tries)."""
    c = ControlClient(port=realtime.control_port, timeout=120)
    inside = []
    try:
        with ProbeLink(realtime.path, timeout=5.0) as link:
            for _ in range(100):
                t0 = c.call("truth")["t"]
                done = {}
                th = threading.Thread(target=lambda: done.update(c.call("advance", s=86400.0)))
                th.start()
                while th.is_alive():
                    t = link.survey().t_ms / 1000.0
                    if t0 + 1.0 < t < t0 + 86399.0:
                        inside.append(t)
                th.join(60)
                assert done["ok"]
                if inside:
                    break
    finally:
        c.close()
    assert inside, "no survey was answered while the advance ran"


def test_acquire_temperature_against_a_plain_inclino_emulate(tmp_path):
    link = tmp_path / "probe"
    emu = subprocess.Popen([BIN, "emulate", "--link", str(link)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        first = emu.stdout.readline()
        second = emu.stdout.readline()
        assert "probe on" in first and "control channel" in second, (first, second)
        port = second.split("127.0.0.1:")[1].split()[0]
        out = tmp_path / "run.csv"
        r = subprocess.run([BIN, "acquire", "--port", str(link), "--bench", f"127.0.0.1:{port}", "--procedure",
                            "temperature", "--temperatures", "24,27", "--reads", "2", "--ramp-poses", "1",
                            "--soak-window-min", "2", "--interval-min", "1", "--average", "4", "-o", str(out), "--quiet"],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        rows = [ln for ln in out.read_text().splitlines() if ln and not ln.startswith("#")][1:]
        temps = [float(x.split(",")[4]) for x in rows]
        assert len(rows) >= 24 and max(temps) > 26.0 and min(temps) < 25.0
    finally:
        emu.send_signal(signal.SIGINT)
        try:
            emu.wait(30)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()


def test_idle_control_clients_time_out():
    e = Emulator("typical", control_port=0, realtime=False, control_idle_s=0.5).start()
    idle = []
    try:
        for _ in range(MAX_CLIENTS):
            idle.append(socket.create_connection(("127.0.0.1", e.control_port)))
        time.sleep(0.2)
        extra = ControlClient(port=e.control_port, timeout=5)
        try:  # the bench is locked out while they hold every place ...
            with pytest.raises((ConnectionError, OSError, ValueError)):
                ans = extra.call("status")
                if not ans.get("ok"):
                    raise ConnectionError(ans.get("error"))
        finally:
            extra.close()
        time.sleep(1.5)  # ... until they are closed for idleness
        c = ControlClient(port=e.control_port, timeout=5)
        try:
            st = c.call("status")
            assert st["ok"] and st["control"]["dropped_idle"] >= MAX_CLIENTS
        finally:
            c.close()
    finally:
        for s in idle:
            s.close()
        e.stop()


def test_a_busy_client_is_not_idle():
    """A client that keeps asking is never closed for idleness."""
    e = Emulator("typical", control_port=0, realtime=False, control_idle_s=0.5).start()
    c = ControlClient(port=e.control_port, timeout=5)
    try:
        for _ in range(8):
            assert c.call("truth")["ok"]
            time.sleep(0.2)
    finally:
        c.close()
        e.stop()
