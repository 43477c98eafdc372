"""`inclino acquire` interrupted: the message names the rows RUN.csv.part
kept, a .part is never overwritten, `--resume` finishes the run; the header
says who and when (probe serial, firmware, calibration CRC and sequence, UTC
start, the samples the probe averaged -- asked of it, --average or not --
and the reading noise measured at the poses), each row its utc_s."""
import numpy as np
import pytest

from inclino import cli
from inclino.formats import dataset
from inclino.formats.survey_log import parse_utc
from inclino.procedures import acquire as acq
from inclino.procedures.turntable_emulated import EmulatedTurntable
from inclino.link.serial_link import ProbeLink
from inclino_emu.runner import Emulator


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


class StopsAt(EmulatedTurntable):
    """The emulated turntable, with Ctrl-C (or an operator's `q`) before move k."""

    def __init__(self, spec, k):
        super().__init__(spec)
        self.k = k

    def move(self, step, index, total):
        if index == self.k:
            raise KeyboardInterrupt
        super().move(step, index, total)


def test_interrupted_run_says_what_it_kept_and_resumes(tmp_path, capsys, rng):
    out = tmp_path / "run.csv"
    part = tmp_path / "run.csv.part"
    k = int(rng.integers(3, 11))
    with Emulator("typical", control_port=0, realtime=False) as emu:
        bench = f"127.0.0.1:{emu.control_port}"
        ident = cli.main(["identify", "--port", emu.path])
        capsys.readouterr()
        with ProbeLink(emu.path, timeout=2.0) as link:
            table = StopsAt(bench, k)
            with pytest.raises(KeyboardInterrupt) as ex:
                acq.acquire(link, "twelve-position", str(out), table, quiet=True)
            table.close()
        assert f"{k - 1} rows kept in {part}" in str(ex.value) and f"--resume {part}" in str(ex.value)
        assert not out.exists()
        kept = part.read_text()
        # the same command again does not overwrite what was kept
        rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench, "--procedure", "twelve-position",
                         "-o", out, "--quiet")
        assert rc == 2 and "--resume" in err and f"{k - 1} rows" in err and part.read_text() == kept
        # another procedure's .part is not continued
        rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench, "--procedure", "multi-position",
                         "--resume", part, "--quiet")
        assert rc == 2 and "not resumed" in err and part.read_text() == kept
        rc, o, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench, "--procedure", "twelve-position",
                         "--resume", part, "--quiet")
        assert rc == 0, err
        assert "12 rows" in o and not part.exists()
    ds = dataset.read_raw(str(out))
    assert len(ds) == 12
    steps = acq.procedure_steps("twelve-position")
    assert np.allclose(ds.columns["inc_deg"], [s.inc for s in steps])
    assert np.allclose(ds.columns["tf_deg"], [s.tf for s in steps])
    text = out.read_text()
    assert text.count("# start_utc=") == 1 and text.count("t_s,inc_deg") == 1
    m = ds.meta
    assert m["samples_averaged"] == 16 and m["firmware"].count(".") == 2 and len(m["calibration_crc"]) == 4
    assert "calibration_sequence" in m and str(m["probe_serial"]) == str(emu.probe.scenario.serial)
    # the reading noise at the poses (the typical probe: 1.5e-4 g and 5 nT per sample at 16 samples)
    assert 0.3e-4 < m["reading_noise_acc_g"] < 4e-4 and 1.0 < m["reading_noise_mag_nT"] < 12.0
    assert m["readings_per_row"] == 3
    utc = np.array([float(ln.split(",")[-1]) for ln in text.splitlines()
                    if ln and not ln.startswith(("#", "t_s"))])
    assert np.all(np.diff(utc) > 0) and utc[0] >= 0
    assert parse_utc(m["start_utc"], "run") > 0


def test_quit_with_no_row_taken_leaves_nothing(tmp_path, capsys):
    out = tmp_path / "run.csv"
    with Emulator("ideal", control_port=0, realtime=False) as emu:
        with ProbeLink(emu.path, timeout=2.0) as link:
            table = StopsAt(f"127.0.0.1:{emu.control_port}", 1)
            with pytest.raises(KeyboardInterrupt) as ex:
                acq.acquire(link, "twelve-position", str(out), table, quiet=True)
            table.close()
    assert "nothing kept" in str(ex.value) and not (tmp_path / "run.csv.part").exists()


def _interrupted(emu, out) -> str:
    """A twelve-position run into `out` interrupted at its sixth pose (its
    .part left); the bench's address."""
    bench = f"127.0.0.1:{emu.control_port}"
    with ProbeLink(emu.path, timeout=2.0) as link:
        table = StopsAt(bench, 6)
        with pytest.raises(KeyboardInterrupt):
            acq.acquire(link, "twelve-position", str(out), table, quiet=True)
        table.close()
    return bench


def test_resume_after_a_row_cut_short_takes_that_pose_again(tmp_path, capsys):
    """A run killed (or the power lost) while writing a row leaves the
    .part's last row cut short; --resume drops it, says so and takes that
    pose again, instead of gluing the next row onto it (a 20-cell row
    that calibrate then refuses)."""
    out, part = tmp_path / "run.csv", tmp_path / "run.csv.part"
    with Emulator("typical", control_port=0, realtime=False) as emu:
        bench = _interrupted(emu, out)
        part.write_text(part.read_text()[:-40])            # row 5 cut mid-number
        rc, o, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench, "--procedure", "twelve-position",
                         "--resume", part, "--quiet")
        assert rc == 0, err
        assert "last row was cut short" in err and "pose 5 is taken again" in err and "12 rows" in o
    ds = dataset.read_raw(str(out))
    steps = acq.procedure_steps("twelve-position")
    assert len(ds) == 12 and np.allclose(ds.columns["tf_deg"], [s.tf for s in steps])


def test_resume_refuses_a_part_damaged_in_the_middle(tmp_path, capsys):
    out, part = tmp_path / "run.csv", tmp_path / "run.csv.part"
    with Emulator("typical", control_port=0, realtime=False) as emu:
        bench = _interrupted(emu, out)
        lines = part.read_text().splitlines(keepends=True)
        lines[-3] = lines[-3][:30] + "\n"                     # a row in the middle cut short
        part.write_text("".join(lines))
        rc, _, err = run(capsys, "acquire", "--port", emu.path, "--bench", bench, "--procedure", "twelve-position",
                         "--resume", part, "--quiet")
    assert rc == 2 and "cut short in the middle of the run" in err and err.count("\n") == 1, err
    assert part.read_text() == "".join(lines) and not out.exists()
