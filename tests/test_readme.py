"""The README's five minutes on the emulator run as written: the block after
the `hands-on` marker, the `inclino emulate` line in the background (its
control port swapped for a free one, so that two runs of the suite on one
machine do not meet), every other line in order in an empty folder, each
exiting 0; and docs/README.md indexes every document."""
import os
import re
import shlex
import signal
import socket
import subprocess
import sys

from inclino import cli


def _hands_on(root) -> list[str]:
    text = (root / "README.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- hands-on[^>]*-->\n```sh\n(.*?)```", text, re.S)
    assert m, "README.md has no hands-on block"
    lines = [re.sub(r"\s+#.*$", "", line).strip() for line in m.group(1).splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_readme_hands_on_runs_as_written(root, tmp_path, monkeypatch, capsys):
    lines = _hands_on(root)
    emulate = [line for line in lines if line.startswith("inclino emulate")]
    rest = [line for line in lines if not line.startswith("inclino emulate")]
    assert len(emulate) == 1 and all(line.startswith("inclino ") for line in rest)
    assert [shlex.split(line)[1] for line in rest] == ["identify", "survey", "acquire", "calibrate", "download",
                                                       "verify", "accept"]
    port = re.search(r"--control (\d+)", emulate[0]).group(1)
    free = str(_free_port())

    def swap(line):
        return shlex.split(line.replace(port, free))

    exe = os.path.join(os.path.dirname(sys.executable), "inclino")  # the command the README's path gives
    monkeypatch.chdir(tmp_path)
    proc = subprocess.Popen([exe] + swap(emulate[0])[1:], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    outputs = {}
    try:
        first = proc.stdout.readline()
        assert first.startswith("inclino emulator: probe on"), first + proc.stderr.read()
        proc.stdout.readline()  # the control channel's address
        for line in rest:
            argv = swap(line)[1:]
            rc = cli.main(argv)
            out, err = capsys.readouterr()
            assert rc == 0, f"{line}: exit {rc}\n{out}\n{err}"
            outputs[argv[0]] = out
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
    assert proc.returncode == 0, err
    # what the README says to look for
    assert "selftest               0x0000: pass" in outputs["identify"]
    assert "FAIL G" in outputs["survey"]
    for name in ("calibrate", "verify", "accept"):
        assert outputs[name].strip().splitlines()[-1].startswith("verdict: PASS"), outputs[name]
    m = re.search(r"azimuth +RMS ([\d.]+) -> ([\d.]+) deg", outputs["accept"])
    assert float(m.group(1)) > 0.3 and float(m.group(2)) < 0.15, m.group(0)
    assert (tmp_path / "run.csv").exists() and (tmp_path / "cal.json").exists()


def test_docs_index_lists_every_document(root):
    index = (root / "docs" / "README.md").read_text(encoding="utf-8")
    listed = set(re.findall(r"\]\(([\w.-]+\.md)\)", index))
    have = {p.name for p in (root / "docs").glob("*.md")} - {"README.md"}
    assert have <= listed, f"not in docs/README.md: {sorted(have - listed)}"
    assert listed <= have, f"docs/README.md lists missing files: {sorted(listed - have)}"
    for role in ("Bench technician", "Survey engineer", "Algorithm engineer", "Firmware engineer", "Contributor"):
        assert f"**{role}**" in index
