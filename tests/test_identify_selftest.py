"""`inclino identify` on probes whose parts fail: the firmware's self-test
status word (firmware/src/app_main.c, docs/protocol.md) and what identify
says it means.  Its own module: each case starts an emulated probe, and a
process holds one at a time (the module-scoped one of test_probe_cli.py
would lose its firmware)."""
import functools
import json

import pytest

from inclino import cli
from inclino_emu import adis16210 as ad
from inclino_emu import runner


def run(capsys, *argv):
    rc = cli.main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize("faults, word, says", [
    ({}, 0x0000, "pass: the ADIS16210 passed its automatic self-test"),
    ({"adis_faults": {"self_test_fails": True}}, 0x0004, "accelerometer self-test failed (ADIS16210 DIAG_STAT[5]"),
    ({"adc_absent": True}, 0x0002, "fluxgate ADC failed to start"),
    ({"adis_faults": {"prod_id": 0x4052}}, 0x0001, "accelerometer failed to start"),
])
def test_identify_says_what_the_self_test_word_means(monkeypatch, capsys, faults, word, says):
    """The firmware's status word (app_main.c) from a probe whose part fails,
    and identify's reading of it."""
    kw = dict(faults)
    if "adis_faults" in kw:
        kw["adis_faults"] = ad.AdisFaults(**kw["adis_faults"])
    monkeypatch.setattr(runner, "EmulatedProbe", functools.partial(runner.EmulatedProbe, **kw))
    with runner.Emulator("ideal", control_port=None, realtime=False) as e:
        rc, out, _ = run(capsys, "identify", "--port", e.path)
        rc2, js, _ = run(capsys, "identify", "--port", e.path, "--json")
    line = next(x for x in out.splitlines() if x.startswith("selftest "))
    assert rc == rc2 == 0 and line.split()[1] == f"0x{word:04X}:" and says in line
    d = json.loads(js)
    assert d["selftest"] == word and any(says in m for m in d["selftest_meaning"])
    assert len(d["selftest_meaning"]) == 1
