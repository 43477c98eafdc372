"""Ctrl-C (docs/cli.md, "Interrupts"): handled from the first line of the
entry point, one line and exit 130, never a traceback; and `flash` saying
what the flash state really is in every window of a flash, each window
checked against the emulated probe's flash afterwards (its descriptor
decoded independently, tests/bootimg.py)."""
import os
import signal
import subprocess
import sys
import time

import pytest

from bootimg import decode_descriptor, expected_ranges, random_chunks, write_srec
from inclino import cli
from inclino.boot import flashing
from inclino.cli import probe as cli_probe
from inclino.link.serial_link import ProbeLink
from inclino_emu.runner import Emulator

BIN = os.path.join(os.path.dirname(sys.executable), "inclino")


# ------------------------------------------------------------ from the first line
def test_interrupt_while_the_command_line_is_imported():
    """A KeyboardInterrupt raised while inclino.cli and the library are
    imported (an import hook raises it at a chosen module) is one line."""
    for module in ("inclino.cli", "inclino.cli.analysis", "inclino.cli.paths", "inclino.formats.safeio",
                   "numpy"):
        code = (
            "import sys, importlib.abc\n"
            "class Stop(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path, target=None):\n"
            f"        if name == {module!r}:\n"
            "            raise KeyboardInterrupt\n"
            "sys.meta_path.insert(0, Stop())\n"
            "from inclino.entry import main\n"
            "raise SystemExit(main(['calibrate', 'x.csv', '-o', 'y.json']))\n")
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
        assert r.returncode == 130 and r.stderr == "inclino: interrupted\n", (module, r.stderr)


def test_interrupt_while_the_parser_is_built(monkeypatch, capsys):
    def boom():
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "build_parser", boom)
    assert cli.main(["identify"]) == 130
    assert capsys.readouterr().err == "inclino: interrupted\n"


def test_an_import_cut_short_by_ctrl_c_is_the_interruption(monkeypatch, capsys):
    """numpy's C core, interrupted while it imports datetime, raises
    ImportError ('PyCapsule_Import could not import module "datetime"'): the
    KeyboardInterrupt is lost (seen once in the real-process test below, at
    0.1 s).  After a Ctrl-C it is the interruption; without one an import
    error is not hidden."""
    from inclino import entry

    def cut(argv):
        raise ImportError('PyCapsule_Import could not import module "datetime"')
    monkeypatch.setattr(cli, "main", cut)
    monkeypatch.setitem(entry._state, "armed", False)
    monkeypatch.setitem(entry._state, "signalled", True)
    assert entry.main(["identify"]) == 130
    assert capsys.readouterr().err == "inclino: interrupted\n"
    monkeypatch.setitem(entry._state, "signalled", False)
    with pytest.raises(ImportError):
        entry.main(["identify"])


def test_a_ctrl_c_after_the_command_finished_is_held(monkeypatch):
    """A command that returns quickly (a refusal 0.4 s after the start) and a
    SIGINT that comes while the interpreter shuts down: the handler raised
    KeyboardInterrupt inside a module lock's callback, which Python printed
    as "Exception ignored ... Traceback ... KeyboardInterrupt".  Once main has
    returned the signal is held."""
    from inclino import entry

    monkeypatch.setattr(cli, "main", lambda argv: 2)
    monkeypatch.setitem(entry._state, "pending", False)
    assert entry.main(["calibrate"]) == 2
    try:
        entry._hold(signal.SIGINT, None)  # the signal, after the command's end: no exception
    except KeyboardInterrupt:
        pytest.fail("a SIGINT after the command's end raised KeyboardInterrupt")
    assert entry._state["pending"]
    monkeypatch.setitem(entry._state, "pending", False)


def test_a_ctrl_c_inside_a_module_locks_callback_is_sent_again(monkeypatch):
    """The signal inside importlib's weakref callback (`cb`): raised there,
    Python printed "Exception ignored ... KeyboardInterrupt" and the command
    went on.  It is sent again, for after the callback; elsewhere it raises."""
    from inclino import entry

    sent = []
    monkeypatch.setattr(entry.os, "kill", lambda pid, sig: sent.append((pid, sig)))
    monkeypatch.setitem(entry._state, "armed", True)
    ns = {}
    exec(compile("def cb(ref):\n    return sys._getframe()\n", "<frozen importlib._bootstrap>", "exec"),
         {"sys": sys}, ns)
    entry._hold(signal.SIGINT, ns["cb"](None))
    assert sent == [(os.getpid(), signal.SIGINT)]
    with pytest.raises(KeyboardInterrupt):
        entry._hold(signal.SIGINT, sys._getframe())


@pytest.mark.parametrize("delay", [0.0, 0.02, 0.05, 0.1, 0.2, 0.4, 0.8])
def test_ctrl_c_early_in_a_real_process(tmp_path, delay):
    """SIGINT at moments across the start-up of a command (imports, parser,
    the first file read), counted from the entry point's first line (the
    child says when it is there, as the console script is: the interpreter's
    own start-up, site imports included, comes before any program's first
    line, docs/cli.md): never a traceback."""
    run = tmp_path / "run.csv"
    run.write_text("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n" + "0,0,1,20000,0,40000\n" * 50000)
    code = ("import sys\nfrom inclino.entry import main\nsys.stdout.write('started\\n'); sys.stdout.flush()\n"
            f"raise SystemExit(main(['calibrate', {str(run)!r}, '-o', {str(tmp_path / 'cal.json')!r}]))\n")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert p.stdout.readline() == "started\n"
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    if p.returncode == 130:
        assert err.splitlines()[-1].startswith("inclino: interrupted"), err
    assert not (tmp_path / "cal.json").exists() or p.returncode in (0, 1)


# ------------------------------------------------------------ flash: every window
@pytest.fixture
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def _interrupt_at(monkeypatch, code, nth=1, when="after"):
    """Ctrl-C before the nth request of `code` is sent, or right after its
    answer came back."""
    real = ProbeLink.request
    state = {"seen": 0, "armed": True}

    def request(self, cmd, payload=b"", timeout=None, expect=None):
        c = cmd if isinstance(cmd, int) else None
        hit = False
        if state["armed"] and c == code:
            state["seen"] += 1
            hit = state["seen"] == nth
        if hit and when == "before":
            state["armed"] = False
            raise KeyboardInterrupt
        ans = real(self, cmd, payload, timeout=timeout, expect=expect)
        if hit:
            state["armed"] = False
            raise KeyboardInterrupt
        return ans
    monkeypatch.setattr(ProbeLink, "request", request)
    return state


def _truth(emu, chunks):
    """What the probe's flash holds: 'new', 'old' (a valid application that is
    not the image) or 'none'; and whether it runs its application."""
    with emu._lock:
        d = decode_descriptor(emu.probe.flash)
        mode = emu.probe.mode
    if d is None:
        return "none", mode
    want = [(a, len(b)) for a, b in expected_ranges(chunks)]
    return ("new" if [(a, n) for a, n, _ in d["ranges"]] == want else "old"), mode


B_IDENTIFY, B_ERASE, B_PROGRAM, B_READ, B_CRC, B_COMMIT, B_RUN = range(0x40, 0x47)
BOOTLOADER = 0x21

# (window, request code, nth, before/after) -> the message's words, the flash's truth
WINDOWS = [
    ("first identify", B_IDENTIFY, 1, "before", "nothing was changed on the probe", "old"),
    ("asked the bootloader", BOOTLOADER, 1, "after", "nothing was erased", "old"),
    ("in the bootloader, before any erase", B_ERASE, 1, "before", "nothing was erased", "old"),
    ("first erase done", B_ERASE, 1, "after", "the application is erased", "none"),
    ("programming", B_PROGRAM, 2, "after", "the application is erased", "none"),
    ("verifying", B_READ, 1, "after", "the application is erased", "none"),
    ("range CRC", B_CRC, 1, "after", "the application is erased", "none"),
    ("before the commit", B_COMMIT, 1, "before", "the application is erased", "none"),
    ("the commit answered", B_COMMIT, 1, "after", "the new application is flashed and committed", "new"),
    ("identify after the commit", B_IDENTIFY, 4, "after", "the new application is flashed and committed", "new"),
    ("run sent", B_RUN, 1, "after", "the new application is flashed and committed", "new"),
]


@pytest.mark.parametrize("window,code,nth,when,words,truth", WINDOWS, ids=[w[0] for w in WINDOWS])
def test_flash_interrupt_message_is_true_in_every_window(emu, tmp_path, capsys, monkeypatch, window, code,
                                                         nth, when, words, truth):
    chunks = random_chunks(11, [(0x7C0000, 900)])
    img = write_srec(tmp_path / "app.s19", chunks)
    monkeypatch.setattr(cli_probe, "_tqdm_progress", lambda: (None, lambda: None))
    state = _interrupt_at(monkeypatch, code, nth, when)
    # the probe answers in every window (only the host is interrupted): a long timeout costs nothing here and
    # keeps the state question after Ctrl-C from reading a slow answer on a loaded machine as none
    rc = cli.main(["flash", "--port", emu.path, "--timeout", "5", img])
    err = capsys.readouterr().err
    assert not state["armed"], f"the flash never reached {window}"
    assert rc == 130 and err.count("\n") == 1 and err.startswith("inclino: interrupted: "), err
    assert words in err, (window, err)
    got, mode = _truth(emu, chunks)
    assert got == truth, (window, got, err)
    if "nothing was changed" in err:
        assert mode == "app"
    if "erased" in err and "nothing was erased" not in err:
        assert mode == "boot"
