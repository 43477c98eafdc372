"""The technician's commands against the emulated probe over its
pseudo-terminal: identify, survey (table, CSV, JSON, LAS), download and
verify, refusals that write nothing, and a download that survives a noisy
line, a disconnect and a power cut at every flash step."""
import json

import numpy as np
import pytest

from inclino import cli
from inclino.formats.calfile import Calibration
from inclino.link.serial_link import ProbeLink
from inclino_emu.runner import Emulator


@pytest.fixture(scope="module")
def emu():
    e = Emulator("typical", control_port=0, realtime=False).start()
    yield e
    e.stop()


def inverse_cal(scn, serial=None, scale=1.0) -> Calibration:
    """The calibration that undoes the scenario's linear sensor model."""
    def tri(model):
        A, c = model.linear()
        return (np.linalg.inv(A) * scale).tolist(), list(map(float, c))
    am, ab = tri(scn.acc)
    mm, mb = tri(scn.mag)
    return Calibration(acc_m=am, acc_b=ab, mag_m=mm, mag_b=mb, method="joint",
                       probe_serial=str(scn.serial if serial is None else serial))


def run(capsys, *argv):
    rc = cli.main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_identify_and_survey_formats(emu, ctl, capsys, tmp_path):
    ctl.call("move", inc=30, azi=120, tf=45)
    rc, out, _ = run(capsys, "identify", "--port", emu.path, "--json")
    assert rc == 0 and json.loads(out)["product"] == "INCLINO-PROBE"
    rc, out, _ = run(capsys, "survey", "--port", emu.path, "--count", "3", "--csv")
    lines = [ln for ln in out.strip().splitlines() if not ln.startswith("#")]
    assert rc == 0 and lines[0].startswith("t_s,inc_deg,azi_deg") and len(lines) == 4
    meta = dict(ln[2:].split("=", 1) for ln in out.splitlines() if ln.startswith("# ") and "=" in ln)
    assert meta["probe_serial"] == str(emu.probe.scenario.serial) and meta["start_utc"].endswith("Z")
    rc, out, _ = run(capsys, "survey", "--port", emu.path, "--json")
    d = json.loads(out)
    assert abs(d["inc_deg"] - 30) < 5 and d["qc_verdict"].startswith(("PASS", "FAIL"))
    assert d["samples"] == 16 and d["utc"].endswith("Z") and d["probe"]["firmware"].count(".") == 2
    las = tmp_path / "run.las"
    rc, out, _ = run(capsys, "survey", "--port", emu.path, "--stream", "--period-ms", "20", "--count", "5",
                     "--las", str(las))
    rows = [ln for ln in out.strip().splitlines() if "PASS" in ln or "FAIL" in ln]
    assert rc == 0 and len(rows) == 5
    import lasio

    log = lasio.read(str(las))
    assert log.index.size == 5 and set(["INC", "AZI", "GTF", "GTOT", "BTOT", "DIP"]) <= set(log.keys())
    assert np.all(np.diff(log.index) > 0) and abs(log["INC"][0] - 30) < 5


def test_download_verify_and_the_correction(emu, ctl, capsys, tmp_path):
    scn = emu.probe.scenario
    cal = inverse_cal(scn)
    f = tmp_path / "cal.json"
    f.write_text(cal.to_json())
    rc, out, _ = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet")
    assert rc == 0 and out.startswith("downloaded: slot")
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(f), "--json")
    v = json.loads(out)
    assert rc == 0 and v["storage_ok"] and v["correction_ok"] and v["checks"] == 3
    # the probe is now calibrated: surveys are near the turntable pose
    ctl.call("move", inc=45, azi=200, tf=300)
    rc, out, _ = run(capsys, "survey", "--port", emu.path, "--json")
    d = json.loads(out)
    assert abs(d["inc_deg"] - 45) < 0.1 and abs(d["azi_deg"] - 200) < 0.5
    # another file does not verify, and says why
    other = inverse_cal(scn, scale=1.01)
    g = tmp_path / "other.json"
    g.write_text(other.to_json())
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(g))
    assert rc == 1 and "FAIL" in out and "not the file's" in out


def with_terms(cal: Calibration) -> Calibration:
    """cal with the typical scenario's temperature terms, applied by the firmware (image version 2)."""
    from inclino.benchmarks.temperature import typical_block

    cal.temperature = typical_block()
    return cal


def test_download_verify_temperature_terms(emu, ctl, capsys, tmp_path):
    """A file with temperature terms downloads as a version 2 image and
    verifies bit for bit over the link (the raw record's temperature at the
    firmware's resolution); the same M, b without the terms do not."""
    scn = emu.probe.scenario
    f = tmp_path / "cal_t.json"
    f.write_text(with_terms(inverse_cal(scn)).to_json())
    rc, out, _ = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet")
    assert rc == 0 and out.startswith("downloaded: slot")
    with ProbeLink(emu.path, timeout=2.0) as link:
        slot = link.identify().cal_slot
        assert len(link.cal_read(slot)[3]) == 192
        assert link.raw().temp_q6 is not None
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(f), "--json")
    v = json.loads(out)
    assert rc == 0 and v["storage_ok"] and v["correction_ok"] and v["checks"] == 3
    g = tmp_path / "cal_plain.json"
    g.write_text(inverse_cal(scn).to_json())
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(g))
    assert rc == 1 and "not the file's" in out


def _active(emu):
    with ProbeLink(emu.path, timeout=2.0) as link:
        i = link.identify()
    return i.cal_slot, i.cal_sequence, i.cal_crc


def test_refusals_write_nothing(emu, ctl, capsys, tmp_path):
    before = _active(emu)
    scn = emu.probe.scenario
    wrong = tmp_path / "wrong.json"
    wrong.write_text(inverse_cal(scn, serial=scn.serial + 1).to_json())
    rc, _, err = run(capsys, "download", "--port", emu.path, "--cal", str(wrong), "--quiet")
    assert rc == 3 and "another probe" in err or "is for probe" in err
    assert err.count("\n") == 1 and _active(emu) == before
    corrupt = tmp_path / "corrupt.json"
    corrupt.write_text('{"format": 1, "acc_m": [[1, 0')
    rc, _, err = run(capsys, "download", "--port", emu.path, "--cal", str(corrupt))
    assert rc == 3 and "not valid JSON" in err and _active(emu) == before
    singular = json.loads(inverse_cal(scn).to_json())
    singular["mag_m"] = [[1, 0, 0], [1, 0, 0], [0, 0, 1]]
    singular.pop("fixed", None)
    s = tmp_path / "singular.json"
    s.write_text(json.dumps(singular))
    rc, _, err = run(capsys, "download", "--port", emu.path, "--cal", str(s))
    assert rc == 3 and "singular" in err and _active(emu) == before
    rc, _, err = run(capsys, "identify", "--port", str(tmp_path / "no-such-port"))
    assert rc == 4 and "cannot open port" in err
    # --force accepts the other serial's file
    rc, _, _ = run(capsys, "download", "--port", emu.path, "--cal", str(wrong), "--force", "--quiet")
    assert rc == 0 and _active(emu) != before


def test_download_on_a_noisy_line(emu, ctl, capsys, tmp_path):
    f = tmp_path / "cal.json"
    f.write_text(inverse_cal(emu.probe.scenario).to_json())
    ctl.call("faults", bit_error_rate=1e-4, drop_rate=1e-4, dup_rate=1e-4, seed=11)
    for _ in range(3):
        rc, out, err = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet", "--json")
        assert rc == 0, err
        assert json.loads(out)["ok"] is True
    rc, out, _ = run(capsys, "verify", "--port", emu.path, "--cal", str(f))
    assert rc == 0


def test_disconnect_mid_download_then_retry(emu, ctl, capsys, tmp_path):
    f = tmp_path / "cal.json"
    f.write_text(inverse_cal(emu.probe.scenario, scale=0.999).to_json())
    before = _active(emu)
    ctl.call("faults", disconnected=True)
    rc, _, err = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet", "--timeout", "0.3")
    assert rc == 4 and "no answer from the probe" in err and "keeps the calibration" in err
    ctl.call("faults", disconnected=False)
    assert _active(emu) == before  # nothing changed
    rc, out, _ = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet")
    assert rc == 0 and _active(emu) != before


@pytest.mark.heavy
@pytest.mark.parametrize("new_terms", [False, True], ids=["v1", "v2"])
def test_power_cut_at_every_flash_step_of_a_download(emu, ctl, capsys, tmp_path, new_terms, monkeypatch):
    """Cut the power at the n-th flash program/erase of a download, for every
    n: the probe always comes back on the old or the new calibration, never a
    mixed one, and a second download succeeds.  v2: the new file carries
    temperature terms (a 192-byte image over a 120-byte one)."""
    from inclino.link import serial_link

    # the flash command cut short never answers: the host waits --timeout plus the flash allowance before its
    # retry.  A real part's erase needs the 0.5 s allowance; the unthrottled emulator answers a flash command in
    # milliseconds, so 0.1 s is ample and the 45 cuts wait 20 s less (the retry path is the same)
    monkeypatch.setattr(serial_link, "FLASH_EXTRA_S", 0.1)
    scn = emu.probe.scenario
    old = tmp_path / "old.json"
    new = tmp_path / "new.json"
    old.write_text(inverse_cal(scn, scale=1.002).to_json())
    new_cal = inverse_cal(scn, scale=0.998)
    new.write_text((with_terms(new_cal) if new_terms else new_cal).to_json())
    assert run(capsys, "download", "--port", emu.path, "--cal", str(old), "--quiet")[0] == 0
    old_state = _active(emu)
    n_ops = 27 if new_terms else 18  # 1 erase + 1 header + 24 (15) payload programs + 1 commit (docs/flash.md)
    for n in range(1, n_ops + 1):
        assert run(capsys, "download", "--port", emu.path, "--cal", str(old), "--quiet")[0] == 0
        before = _active(emu)
        ctl.call("power_cut", n=n, mode="random")
        rc, out, err = run(capsys, "download", "--port", emu.path, "--cal", str(new), "--quiet", "--json",
                           "--timeout", "0.1")
        after = _active(emu)
        # verify against whichever file the probe now reports
        rc_old = run(capsys, "verify", "--port", emu.path, "--cal", str(old), "--surveys", "1")[0]
        rc_new = run(capsys, "verify", "--port", emu.path, "--cal", str(new), "--surveys", "1")[0]
        assert (rc_old, rc_new) in ((0, 1), (1, 0)), (n, rc, err)
        if rc == 0:
            assert rc_new == 0 and json.loads(out)["ok"]
        else:
            assert "failed" in err or "no answer" in err
        assert after != (0xFF, 0, 0)
    assert ctl.call("status")["power_cuts"] >= n_ops
    assert old_state[2] != 0



def test_set_average(emu, ctl):
    from inclino.link.serial_link import ProbeNak

    with ProbeLink(emu.path, timeout=2.0) as link:
        assert link.set_average(4) == 4
        assert link.survey().count == 4
        with pytest.raises(ProbeNak, match="E_ARGUMENT"):
            link.set_average(0)
        assert link.set_average(16) == 16


def test_a_crc_is_the_same_hex_string_in_every_json(emu, ctl, capsys, tmp_path):
    """download --json and identify --json name the stored image's CRC the
    same way (one form per value: upper-case hex, zero-padded), and it is
    the CRC-16 of the image the probe holds."""
    import binascii
    import re

    f = tmp_path / "cal.json"
    f.write_text(inverse_cal(emu.probe.scenario, scale=1.0005).to_json())
    rc, out, _ = run(capsys, "download", "--port", emu.path, "--cal", str(f), "--quiet", "--json")
    crc = json.loads(out)["image_crc"]
    rc2, out2, _ = run(capsys, "identify", "--port", emu.path, "--json")
    ident = json.loads(out2)
    assert rc == rc2 == 0 and re.fullmatch(r"[0-9A-F]{4}", crc) and ident["calibration_crc"] == crc
    with ProbeLink(emu.path) as link:
        slot = {"A": 0, "B": 1}[ident["calibration_slot"]]
        image = link.cal_read(slot)[3]
    n = len(image) - 4  # the image ends with its CRC and two pad bytes (formats/calimage.py)
    assert f"{binascii.crc_hqx(image[:n], 0xFFFF):04X}" == crc
