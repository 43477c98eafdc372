"""What the link's errors say when a technician's bench goes wrong in the
middle of a command (the bench review, /tmp/bench/REPORT.md): a probe that
answered and then went silent is not a wrong port, and the probe's own text
console answering a request whose frame start the line lost is the probe, on
a noisy line, not another device."""
import pytest

from inclino.link.serial_link import ProbeError, ProbeLink
from inclino_emu.control import ControlClient
from inclino_emu.runner import Emulator


@pytest.fixture(scope="module")
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


@pytest.fixture
def ctl(emu):
    c = ControlClient(port=emu.control_port)
    yield c
    c.call("faults", bit_error_rate=0.0, drop_rate=0.0, dup_rate=0.0, disconnected=False)
    c.close()


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
