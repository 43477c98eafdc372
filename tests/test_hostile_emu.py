"""Hostile clients and faults around the emulated probe and its link: the
control channel's parser and rules (NaN, infinities, huge lines, deep
nesting, non-reading clients), real-time pacing, option rules of the link
commands, a probe left in its bootloader, flash entry points, a calibration
whose own report failed, and the link's messages.  Every case named in the
hostile-input review has a regression here."""
import json
import os
import socket
import threading
import time

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from inclino.link import operations as calops
from inclino import cli
from inclino.boot import flashing
from inclino.boot import image as boot_image
from inclino.cli import probe as cli_probe
from inclino.formats.calfile import Calibration
from inclino.link.serial_link import ProbeError, ProbeInBootloader, ProbeLink
from inclino_emu import control
from inclino_emu import probe as probe_mod
from inclino_emu.control import ControlClient, RequestError, parse_request
from inclino_emu.runner import Emulator

from bootimg import random_chunks, write_srec
from conftest import hypothesis_examples
from test_probe_cli import inverse_cal, run

# generated inputs per property in the suite; the run reported in docs/emulator.md used 10000
EXAMPLES = hypothesis_examples(300)


# ---- the request parser, property-based -----------------------------------------------
json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True, allow_infinity=True) | st.text(),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=20)
hostile = st.one_of(st.none(), st.booleans(), st.text(max_size=5), st.lists(st.integers(), max_size=2),
                    st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 2**70]))


def _num(lo, hi):
    m = 0.1 * (hi - lo)
    return st.one_of(st.floats(lo, hi), st.floats(lo - m, hi + m), st.integers(int(lo - m) - 1, int(hi + m) + 1),
                     hostile)


ARGS = {   # each command's own arguments: mostly near their range, sometimes hostile
    "move": {"inc": _num(0, 180), "azi": _num(0, 360), "tf": _num(0, 360)},
    "temperature": {"temp_c": st.one_of(_num(-55, 125), st.none())},
    "truth": {}, "power_cycle": {}, "status": {},
    "faults": {"bit_error_rate": _num(0, 1), "drop_rate": _num(0, 1), "dup_rate": _num(0, 1),
               "disconnected": st.one_of(st.booleans(), st.booleans(), hostile),
               "seed": st.one_of(st.integers(0, 1000), st.integers(-5, 2**64), hostile)},
    "power_cut": {"n": st.one_of(st.integers(1, 100), st.integers(-3, 2_000_000), hostile),
                  "mode": st.one_of(st.sampled_from(["random", "none", "full"]), st.sampled_from(["half", ""]),
                                    hostile)},
    "chamber": {"setpoint_c": _num(-70, 180), "rate_c_per_min": st.one_of(_num(0, 30), st.none())},
    "advance": {"s": _num(0, 5)},
    "nope": {}, "": {},
}


@st.composite
def requests(draw):
    cmd = draw(st.sampled_from(sorted(ARGS)))
    req = {"cmd": cmd}
    for k, strat in ARGS[cmd].items():
        if draw(st.integers(0, 9)) < 8:          # an argument is left out one time in five
            req[k] = draw(strat)
    if draw(st.integers(0, 19)) == 0:            # now and then an argument nobody takes
        req[draw(st.text(max_size=6))] = draw(json_values)
    return req


def _as_line(obj) -> bytes:
    return json.dumps(obj).encode()   # NaN / Infinity written as Python's json does


@pytest.fixture(scope="module")
def _idle_emus():
    made = []
    yield made
    for e in made:
        e.control.close()
        e.pty.close()


@pytest.fixture
def idle_emu(_idle_emus):
    """An emulator whose loop does not run: handle_line is called directly
    (the handlers are the emulator's own).  Shared by the module's tests
    while it owns the firmware; a new one when another test's probe has
    taken the firmware over (one EmulatedProbe owns it at a time: the
    tests may run in any order)."""
    if not _idle_emus or probe_mod._owner is not _idle_emus[-1].probe:
        _idle_emus.append(Emulator("ideal", control_port=0, realtime=False))
    return _idle_emus[-1]


def _check_answer(ans):
    assert isinstance(ans, dict) and isinstance(ans["ok"], bool)
    json.dumps(ans, allow_nan=False)   # the answer is strict JSON
    if not ans["ok"]:
        assert isinstance(ans["error"], str) and "\n" not in ans["error"] and len(ans["error"]) < 400


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=300))
def test_parser_any_bytes(data):
    try:
        req = parse_request(data)
    except RequestError as e:
        assert str(e)
        event("refused")
    else:
        event("parsed")
        assert isinstance(req, dict) and isinstance(req["cmd"], str)


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(requests(), st.lists(st.tuples(st.integers(0, 10**6), st.binary(max_size=3), st.integers(0, 3)), max_size=4),
       st.sampled_from([b"", b"[" * 20000, b"{" * 17, b"\xc3", b"1" * 70000]))
def test_parser_mutated_requests(req, edits, tail):
    """Well-formed requests with bytes replaced, inserted or cut, and
    hostile tails (deep nesting, a cut UTF-8 sequence, a huge number)."""
    line = bytearray(_as_line(req))
    for pos, data, cut in edits:
        p = pos % (len(line) + 1)
        line[p:p + cut] = data
    line += tail
    try:
        r = parse_request(bytes(line))
    except RequestError as e:
        assert str(e) and len(str(e)) < 400
        event("refused")
    else:
        assert isinstance(r["cmd"], str)
        event("parsed")


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                      HealthCheck.function_scoped_fixture])
@given(requests())
def test_handlers_any_request(idle_emu, req):
    """Requests of the right shape with any values: an answer every time,
    and a refused request changes nothing (the pose, temperature and faults
    are read back through the channel itself)."""
    h = idle_emu.control.handle_line
    before = h(b'{"cmd": "truth"}'), h(b'{"cmd": "faults"}')
    if req["cmd"] in ("power_cut",):
        idle_emu.probe.flash.disarm()
    ans = h(_as_line(req))
    _check_answer(ans)
    event(f"{req['cmd'] or '(empty)'} {'accepted' if ans['ok'] else 'refused'}")
    if not ans["ok"]:
        after = h(b'{"cmd": "truth"}'), h(b'{"cmd": "faults"}')
        assert after[0]["pose"] == before[0]["pose"] and after[1]["faults"] == before[1]["faults"]
    idle_emu.probe.flash.disarm()
    probe = idle_emu.probe
    # whatever was accepted, the firmware can still take a survey
    if ans["ok"] and req["cmd"] in ("move", "temperature"):
        assert probe.survey()["status"] == 0


@pytest.mark.parametrize("line, err", [
    (b'{"cmd":"move","inc":NaN,"azi":0,"tf":0}', "NaN is not a number"),
    (b'{"cmd":"move","inc":Infinity,"azi":0,"tf":0}', "Infinity is not a number"),
    (b'{"cmd":"move","inc":1e999,"azi":0,"tf":0}', "out of range"),
    (b'{"cmd":"temperature","temp_c":NaN}', "NaN is not a number"),
    (b'{"cmd":"temperature","temp_c":1e6}', "temp_c must be a finite number within -55 to 125"),
    (b'{"cmd":"move","inc":500,"azi":0,"tf":0}', "inc must be a finite number within 0 to 180"),
    (b'{"cmd":"move","inc":true,"azi":0,"tf":0}', "inc must be a number"),
    (b'{"cmd":"move","inc":"30","azi":0,"tf":0}', "inc must be a number"),
    (b'{"cmd":"move","inc":30,"azi":0,"tf":0,"speed":3}', "unknown argument 'speed'"),
    (b'{"cmd":"faults","drop_rate":-0.1}', "drop_rate must be a finite number within 0 to 1"),
    (b'{"cmd":"faults","disconnected":"yes"}', "disconnected must be true or false"),
    (b'{"cmd":"faults","seed":1.5}', "seed must be an integer"),
    (b'{"cmd":"power_cut","n":0}', "n counts flash operations from 1"),
    (b'{"cmd":"power_cut","n":1,"mode":"half"}', "mode must be one of"),
    (b'{"cmd":"move","inc":' + b"1" * 5000 + b',"azi":0,"tf":0}', "number too long"),
    (b"[" * 50000, "nested deeper than 16"),
    (b'{"a":' * 40 + b"1" + b"}" * 40, "nested deeper than 16"),
    (b"\xff\xfe", "not UTF-8"),
])
def test_refused_requests(idle_emu, line, err):
    t0 = idle_emu.control.handle_line(b'{"cmd": "truth"}')
    ans = idle_emu.control.handle_line(line)
    _check_answer(ans)
    assert ans["ok"] is False and err in ans["error"], ans
    assert idle_emu.control.handle_line(b'{"cmd": "truth"}')["pose"] == t0["pose"]
    assert idle_emu.probe.survey()["status"] == 0     # the next survey works (it raised ValueError before)


# ---- the running emulator under attack --------------------------------------------------
def _recv_line(sock, timeout=5.0) -> dict:
    sock.settimeout(timeout)
    buf = b""
    while not buf.endswith(b"\n"):
        d = sock.recv(65536)
        if not d:
            break
        buf += d
    return json.loads(buf.split(b"\n")[0])


def _attack(port: int, stop: threading.Event, report: dict):
    """NaN, huge lines, malformed JSON, deep nesting, flooders that never read
    and thousands of connections that never read, until `stop`."""
    held = []
    n_conn = 0
    try:
        # requests that once killed the emulator, answered on a reading connection
        c = socket.create_connection(("127.0.0.1", port), timeout=5)
        for line in (b'{"cmd":"move","inc":NaN,"azi":0,"tf":0}', b'{"cmd":"temperature","temp_c":NaN}',
                     b"{oops", b"[" * 50000, b'{"cmd":"faults","drop_rate":Infinity}'):
            c.sendall(line + b"\n")
            report.setdefault("answers", []).append(_recv_line(c))
        c.sendall(b"x" * (control.MAX_LINE + 10))       # a huge line: answered, then closed
        report["huge"] = _recv_line(c)
        c.close()
        # flooders: requests as fast as the channel takes them, never a read, until dropped
        floods = []
        for _ in range(4):
            f = socket.socket()
            f.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            f.connect(("127.0.0.1", port))
            f.setblocking(False)
            floods.append(f)
        t_end = time.monotonic() + 20
        while floods and time.monotonic() < t_end:
            for f in list(floods):
                try:
                    f.send(b'{"cmd":"truth"}\n' * 20)
                except BlockingIOError:
                    pass
                except OSError:          # dropped by the emulator
                    floods.remove(f)
                    f.close()
                    report["flood_dropped"] = report.get("flood_dropped", 0) + 1
            time.sleep(0.001)
        held.extend(floods)
        # thousands of connections that send a request and never read
        while n_conn < 3000:
            for _ in range(250):
                s = socket.socket()
                s.settimeout(5)
                try:
                    s.connect(("127.0.0.1", port))
                    s.send(b'{"cmd":"status"}\n{"cmd":"move","inc":NaN}\n')
                except OSError:
                    s.close()
                    continue
                held.append(s)
                n_conn += 1
            time.sleep(0.02)
            if len(held) > 1000:
                for s in held[4:]:
                    s.close()
                del held[4:]
    except Exception as e:   # reported to the test
        report["error"] = repr(e)
    finally:
        report["connections"] = n_conn
        report["done"] = time.monotonic()
        stop.wait(30)
        for s in held:
            s.close()


def test_download_completes_while_the_control_channel_is_attacked(tmp_path):
    with Emulator("typical", control_port=0, realtime=True) as emu:
        cal = inverse_cal(emu.probe.scenario)
        stop, report = threading.Event(), {}
        t = threading.Thread(target=_attack, args=(emu.control_port, stop, report), daemon=True)
        # the link is opened before the attack: the attack holds about a thousand
        # sockets in this process, and a pty opened after them would get a
        # descriptor above 1023, which pyserial's select() cannot wait on
        link = ProbeLink(emu.path, timeout=0.5)
        t.start()
        try:
            time.sleep(0.5)   # the attack is under way
            results = []
            with link:
                while "done" not in report or not results:   # downloads, one after another, during it all
                    r = calops.download(link, cal)
                    results.append((time.monotonic(), r))
                ident = link.identify()
        finally:
            stop.set()
            t.join(60)
        assert "error" not in report, report
        assert all(x.ok for _, x in results) and results[0][0] < report["done"]
        assert r.ok and ident.cal_slot == {"A": 0, "B": 1}[r.slot] and ident.cal_sequence == r.sequence
        ans = report["answers"]
        assert [a["ok"] for a in ans] == [False] * 5
        assert "NaN" in ans[0]["error"] and "NaN" in ans[1]["error"] and "not JSON" in ans[2]["error"]
        assert "nested" in ans[3]["error"] and "Infinity" in ans[4]["error"]
        assert report["huge"] == {"ok": False, "error": "line too long"}
        assert report["connections"] >= 1000
        st_ = emu.control.stats
        assert report.get("flood_dropped") == 4 and st_["dropped_slow"] >= 4 and st_["dropped_long"] == 1 and st_["refused"] > 0
        # afterwards the channel serves a new client and the probe its link
        c = ControlClient(port=emu.control_port)
        assert c.call("status")["ok"] is True
        assert c.call("move", inc=10, azi=20, tf=30)["ok"] is True
        c.close()
        assert emu.error is None


def test_a_client_that_does_not_read_is_dropped_not_waited_on():
    with Emulator("ideal", control_port=0, realtime=False) as emu:
        f = socket.socket()
        f.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        f.connect(("127.0.0.1", emu.control_port))
        f.setblocking(False)
        sent = 0
        deadline = time.monotonic() + 20
        while emu.control.stats["dropped_slow"] == 0 and time.monotonic() < deadline:
            try:
                sent += f.send(b'{"cmd":"truth"}\n' * 50)
            except BlockingIOError:
                time.sleep(0.01)
            except OSError:
                break
        assert emu.control.stats["dropped_slow"] == 1
        c = ControlClient(port=emu.control_port, timeout=2)
        st_ = c.call("status")                   # the others are served meanwhile
        assert st_["ok"] and st_["control"]["dropped_slow"] == 1 and st_["control"]["clients"] == 1
        with ProbeLink(emu.path, timeout=0.5) as link:
            assert link.identify().product == "INCLINO-PROBE"
        f.close()
        c.close()


# ---- real time ------------------------------------------------------------------------------
def test_real_time_mode_keeps_to_the_wall_clock_while_acquiring():
    """64-sample surveys take ~0.25 s of probe time each: emulated time must
    not run ahead of the wall clock (it ran 3.9 s of probe time in 0.21 s)."""
    with Emulator("typical", control_port=0, realtime=True) as emu:
        c = ControlClient(port=emu.control_port)
        with ProbeLink(emu.path, timeout=2.0) as link:
            assert link.set_average(64) == 64
            t_emu0, t_wall0 = c.call("status")["t"], time.monotonic()
            waits = []
            for _ in range(4):
                w = time.monotonic()
                link.survey()
                waits.append(time.monotonic() - w)
            t_emu1, t_wall1 = c.call("status")["t"], time.monotonic()
        c.close()
    emu_s, wall_s = t_emu1 - t_emu0, t_wall1 - t_wall0
    assert emu_s > 0.8                                     # four surveys of 64 samples did run
    assert emu_s <= wall_s + 0.05, (emu_s, wall_s)         # never ahead of the wall clock
    assert min(waits) > 0.2                                # each answer came after its acquisition time


# ---- option rules ------------------------------------------------------------------------------
@pytest.mark.parametrize("argv, msg", [
    (["emulate", "--baud", "0"], "--baud 0"),
    (["emulate", "--baud", "-1"], "--baud -1"),
    (["emulate", "--control", "70000"], "--control 70000"),
    (["identify", "--port", "/nonexistent", "--timeout", "nan"], "--timeout nan"),
    (["identify", "--port", "/nonexistent", "--timeout", "0"], "--timeout 0"),
    (["identify", "--port", "/nonexistent", "--baud", "0"], "--baud 0"),
    (["survey", "--port", "/nonexistent", "--count", "-1"], "--count -1"),
    (["survey", "--port", "/nonexistent", "--period-ms", "-5"], "--period-ms -5"),
    (["survey", "--port", "/nonexistent", "--stream", "--period-ms", "70000"], "--period-ms 70000"),
    (["survey", "--port", "/nonexistent", "--count", "0"], "needs --stream"),
    (["verify", "--port", "/nonexistent", "--cal", "x.json", "--surveys", "-1"], "--surveys -1"),
    (["download", "--port", "/nonexistent", "--cal", "x.json", "--timeout", "inf"], "--timeout inf"),
    (["flash", "--port", "/nonexistent", "x.s19", "--timeout", "nan"], "--timeout nan"),
    (["flash", "--port", "/nonexistent", "x.s19", "--attempts", "0"], "--attempts 0"),
])
def test_options_that_cannot_work_exit_2(capsys, argv, msg):
    rc, out, err = run(capsys, *argv)
    assert rc == 2 and err.count("\n") == 1 and msg in err and err.startswith("inclino: error:"), err


# ---- the bootloader, entry points, failed reports, messages ----------------------------------
@pytest.fixture
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def test_interrupted_flash_then_every_command_says_bootloader(emu, tmp_path, capsys, monkeypatch):
    img = write_srec(tmp_path / "app.s19", random_chunks(3, [(0x7C0000, 3000)]))

    def cb(phase, done, total):
        if phase == "program":
            raise KeyboardInterrupt

    monkeypatch.setattr(cli_probe, "_tqdm_progress", lambda: (cb, lambda: None))
    rc, _, err = run(capsys, "flash", "--port", emu.path, img)
    assert rc == 130 and err.strip() == ("inclino: interrupted: the application is erased: the probe stays in "
                                         "its bootloader (no application) until inclino flash is run again")
    cal = inverse_cal(emu.probe.scenario)
    cal.save(str(tmp_path / "cal.json"))
    for argv in (["identify"], ["survey"], ["verify", "--cal", str(tmp_path / "cal.json")],
                 ["download", "--cal", str(tmp_path / "cal.json"), "--quiet"]):
        rc, out, err = run(capsys, argv[0], "--port", emu.path, *argv[1:])
        assert rc == 4 and err.count("\n") == 1, (argv, err)
        assert "is in its bootloader with no application (erased: a flash did not finish)" in err
        assert "run `inclino flash --port" in err and "E_STATE" not in err
    assert emu.probe.mode == "boot"
    monkeypatch.undo()
    rc, out, _ = run(capsys, "flash", "--port", emu.path, img, "--json")
    assert rc == 0 and json.loads(out)["app_running"]
    rc, out, _ = run(capsys, "identify", "--port", emu.path)
    assert rc == 0 and "INCLINO-PROBE" in out


def test_interrupt_before_any_erase_keeps_the_application(emu, tmp_path):
    img = write_srec(tmp_path / "app.s19", random_chunks(4, [(0x7C0000, 64)]))
    with ProbeLink(emu.path, timeout=0.5) as link:
        def cb(phase, done, total):
            raise KeyboardInterrupt
        # the first progress call is the first erase's tick: the erase ran -> erased
        with pytest.raises(KeyboardInterrupt) as ei:
            flashing.flash(link, img, progress=cb)
        assert "the application is erased" in str(ei.value)
        b = flashing._Flasher(link, boot_image.load_image(img), None, flashing.FlashResult(False, img, ""))
        b.in_bootloader = True
        assert "nothing was erased" in flashing._interrupted_state(b, b.res)
        assert flashing._interrupted_state(flashing._Flasher(link, None, None, b.res), b.res) == \
            "nothing was changed on the probe"


@pytest.mark.parametrize("entry, why", [
    (None, "no entry point"),
    (0x7FF100, "inside the bootloader"),
    (0x7A0400, "the probe's data sectors"),
    (0x7FEC10, "the application descriptor"),
    (0x7C8000, "not in the image's code"),
    (0x600000, "outside the P-Flash"),
])
def test_flash_refuses_images_without_a_valid_entry(tmp_path, capsys, entry, why):
    img = write_srec(tmp_path / "app.s19", random_chunks(5, [(0x7C0000, 256)]), entry=entry)
    rc, _, err = run(capsys, "flash", "--port", str(tmp_path / "no-such-port"), img)
    assert rc == 2 and why in err and "nothing was erased" in err and err.count("\n") == 1


def test_download_refuses_a_failed_report_unless_forced(emu, tmp_path, capsys):
    cal = inverse_cal(emu.probe.scenario)
    cal.report = {"passed": False, "reasons": ["azimuth residual 0.9 deg > 0.3 deg"]}
    cal.save(str(tmp_path / "bad.json"))
    with ProbeLink(emu.path) as link:
        seq0 = link.identify().cal_sequence
    rc, _, err = run(capsys, "download", "--port", emu.path, "--cal", str(tmp_path / "bad.json"), "--quiet")
    assert rc == 3 and "report did not pass (azimuth residual 0.9 deg > 0.3 deg)" in err and "--force" in err
    with ProbeLink(emu.path) as link:
        assert link.identify().cal_sequence == seq0              # nothing written
        with pytest.raises(Exception, match="report did not pass"):
            calops.download(link, cal)
    rc, out, _ = run(capsys, "download", "--port", emu.path, "--cal", str(tmp_path / "bad.json"), "--quiet", "--force")
    assert rc == 0 and "downloaded with --force although the calibration's own report did not pass" in out


def test_noisy_and_silent_links_are_told_apart(emu):
    c = ControlClient(port=emu.control_port)
    try:
        c.call("faults", bit_error_rate=0.02, seed=4)
        with ProbeLink(emu.path, timeout=0.2, retries=2) as link:
            with pytest.raises(ProbeError) as ei:
                link.identify()
        assert "the link is noisy" in str(ei.value) and "wrong port" not in str(ei.value)
        c.call("faults", bit_error_rate=0.0, disconnected=True)
        with ProbeLink(emu.path, timeout=0.2, retries=1) as link:
            with pytest.raises(ProbeError) as ei:
                link.identify()
        assert "nothing received (wrong port, wrong baud rate, or the probe is off)" in str(ei.value)
    finally:
        c.call("faults", bit_error_rate=0.0, disconnected=False)
        c.close()


def test_verify_on_an_uncalibrated_probe_is_one_line(emu, tmp_path, capsys):
    cal = inverse_cal(emu.probe.scenario)
    cal.save(str(tmp_path / "cal.json"))
    with ProbeLink(emu.path) as link, pytest.raises(Exception, match="at least 1 survey"):
        calops.verify(link, cal, surveys=0)
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(tmp_path / "cal.json"))
    assert rc == 1 and out.count("\n") == 1 and "the probe has no calibration" in out


def test_download_messages(capsys):
    r = calops.DownloadResult(ok=True, slot="A", sequence=2, image_crc=0x1234, retries=1)
    from inclino.cli import probe as probe_cli
    assert probe_cli.download_line(r) == "downloaded: slot A, sequence 2, image CRC 1234 (1 link retry)"
    r.events = ["attempt 2 succeeded"]
    r.retries = 0
    assert probe_cli.download_line(r).endswith("(attempt 2 succeeded)")

    class Link:      # a link whose probe refuses the image with check code 5
        class stats:
            retries = bytes_out = bytes_in = 0

        def cal_write(self, image, force=False):
            from inclino.link.serial_link import ProbeNak
            raise ProbeNak(0x11, 9, 5)

    cal = Calibration(probe_serial="7")
    with pytest.raises(Exception) as ei:
        calops.download(Link(), cal)
    assert "a coefficient outside the range the probe accepts" in str(ei.value)
    assert "check code" not in str(ei.value)


def test_the_bootloader_itself_refuses_an_entry_outside_the_ranges(tmp_path):
    """COMMIT with the entry in the bootloader or outside every range is
    refused (E_ARGUMENT), nothing committed; a descriptor whose entry lies
    outside its ranges is not valid (the probe stays in its bootloader)."""
    import struct
    import zlib

    from inclino_emu.probe import BOOT_DESC_ADDR, EmulatedProbe, factory_app_image
    from bootimg import decode_descriptor

    with Emulator("ideal", control_port=0, realtime=False) as emu:
        img = factory_app_image()
        with ProbeLink(emu.path, timeout=0.5) as link:
            link.request(0x21, struct.pack(">I", 0x424F4F54))          # BOOTLOADER
            time.sleep(0.1)
            rng = struct.pack(">III", 0x7C0000, len(img), zlib.crc32(img))
            for entry in (0x7FF000, 0x7C0000 + len(img), 0x700000, 0xFFFFFFFF):
                with pytest.raises(Exception) as ei:
                    link.request(0x45, struct.pack(">IB", entry, 1) + rng)
                assert getattr(ei.value, "code", None) == 5, (hex(entry), ei.value)
            assert decode_descriptor(emu.probe.flash)["entry"] == 0x7C0000   # the factory one, untouched
            link.request(0x45, struct.pack(">IB", 0x7C0010, 1) + rng)         # inside: committed
            assert decode_descriptor(emu.probe.flash)["entry"] == 0x7C0010
    # a descriptor written with an entry outside its range (not by COMMIT): not valid
    from inclino_emu.hal import ffi, lib
    from inclino_emu.probe import BOOT_COMMIT_OFFSET, FACTORY_APP_ADDR

    for entry, mode in ((0x7FF000, "boot"), (0x7C0000 + len(img), "boot"), (0x7C0000 + 8, "app")):
        p = EmulatedProbe("ideal", boot=False, factory_app=False)
        a = ffi.new("boot_app_t *")
        a.entry, a.count = entry, 1
        a.range[0].addr, a.range[0].len, a.range[0].crc = FACTORY_APP_ADDR, len(img), zlib.crc32(img)
        hdr, commit = ffi.new("uint8_t[120]"), ffi.new("uint8_t[8]")
        n = lib.boot_desc_build(a, hdr, commit)
        p.flash.load(FACTORY_APP_ADDR, img)
        p.flash.load(BOOT_DESC_ADDR, bytes(hdr)[:n])
        p.flash.load(BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET, bytes(commit))
        p.boot()
        assert p.mode == mode, hex(entry)


def test_flash_off_a_terminal_prints_progress_lines(emu, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("INCLINO_PROGRESS_PERIOD", "0.000001")
    img = write_srec(tmp_path / "app.s19", random_chunks(6, [(0x7C0000, 2048)]))
    rc, out, err = run(capsys, "flash", "--port", emu.path, img)
    assert rc == 0 and "flashed and verified" in out
    lines = err.splitlines()
    for phase in ("erase", "program", "verify"):
        mine = [l for l in lines if l.startswith(f"inclino: flash {phase}: ")]
        assert mine and mine[-1].startswith(f"inclino: flash {phase}: 100% ("), lines
    # with the default period (10 s) a short flash prints each phase's first and last status only
    monkeypatch.delenv("INCLINO_PROGRESS_PERIOD")
    rc, _, err = run(capsys, "flash", "--port", emu.path, img)
    assert rc == 0 and len([l for l in err.splitlines() if l.startswith("inclino: flash ")]) == 6, err
