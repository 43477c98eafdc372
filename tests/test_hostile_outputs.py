"""One output rule: every file a command writes goes through
inclino.formats.safeio, checked against every input of the command and every
other output, before any work and again at each write (a PNG in a folder,
a symlink planted in that folder).

Named regressions: each case below destroyed an input or an output with
exit 0 before the rule was enforced in the command line itself
(inclino.cli.paths, docs/cli.md "Output files")."""
import hashlib
import os

import numpy as np
import pytest

from inclino import cli
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def digest(path) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def one_error(err, needle=""):
    assert err.startswith("inclino: error: ") and err.count("\n") == 1, err
    assert needle in err, err


def write_listing(path, n=12):
    md = np.arange(n) * 30.0
    inc = np.linspace(0, 40, n)
    azi = np.full(n, 120.0)
    with open(path, "w") as f:
        f.write("md_m,inc_deg,azi_deg\n")
        for i in range(n):
            f.write(f"{md[i]:.3f},{inc[i]:.4f},{azi[i]:.4f}\n")


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    """A joint calibration with its covariance (toolmodel needs one)."""
    from inclino.calib import fit, runs
    from inclino.model.scenario import generate_raw, load_scenario

    s = load_scenario("typical")
    ds = generate_raw(s, *runs.multi_position(), seed=int(RNG.integers(1 << 30)))
    ds.meta.update(field_nT=50000.0, dip_deg=60.0)
    cal, _ = fit(ds, "joint")
    p = tmp_path_factory.mktemp("cal") / "cal.json"
    cal.save(str(p))
    return str(p)


@pytest.fixture
def work(tmp_path, calibration):
    import shutil

    c = tmp_path / "c.json"
    shutil.copy(calibration, c)
    s = tmp_path / "s.csv"
    write_listing(s)
    r = tmp_path / "r.json"
    assert cli.main(["reffield", "--declination", "3", "--dip", "60", "--field", "50000", "-o", str(r)]) == 0
    return tmp_path, str(c), str(s), str(r)


def _unchanged(paths, before):
    assert [digest(p) for p in paths] == before


# ------------------------------------------------------------ each destroyed input
def test_toolmodel_output_over_its_calibration(work, capsys):
    d, c, s, r = work
    before = digest(c)
    rc, out, err = run(capsys, "toolmodel", "--cal", c, "--dip", "60", "--field", "50000", "-o", c)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(c) == before


def test_trajectory_plot_over_its_listing(work, capsys):
    d, c, s, r = work
    before = digest(s)
    rc, out, err = run(capsys, "trajectory", s, "--declination", "3", "-o", d / "t.csv", "--plot", s)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(s) == before and not os.path.exists(d / "t.csv")


def test_trajectory_las_over_its_calibration(work, capsys):
    d, c, s, r = work
    before = digest(c)
    rc, out, err = run(capsys, "trajectory", s, "--declination", "3", "--uncertainty", "--cal", c,
                       "-o", d / "t.csv", "--las", c)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(c) == before


@pytest.mark.parametrize("opt", ["--plot", "-o"])
def test_reference_file_overwritten_by_an_output(work, capsys, opt):
    d, c, s, r = work
    before = digest(r)
    argv = ["trajectory", s, "--ref", r, "-o", d / "t.csv"] if opt == "--plot" else ["trajectory", s, "--ref", r]
    rc, out, err = run(capsys, *argv, opt, r)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(r) == before


def test_reffield_output_over_its_reference_file(work, capsys):
    d, c, s, r = work
    before = digest(r)
    rc, out, err = run(capsys, "reffield", "--ref", r, "-o", r)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(r) == before


def test_accept_save_over_its_calibration(work, capsys):
    """Refused before the port is opened (the port here does not exist)."""
    d, c, s, r = work
    before = digest(c)
    rc, out, err = run(capsys, "accept", "--port", d / "no-port", "--cal", c, "-o", c)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(c) == before


def test_two_outputs_naming_one_file(work, capsys):
    d, c, s, r = work
    rc, out, err = run(capsys, "trajectory", s, "--declination", "3", "-o", d / "t.csv", "--las", d / "t.csv")
    assert rc == 2
    one_error(err, "t.csv")
    assert not os.path.exists(d / "t.csv")


def test_two_outputs_one_file_through_a_symlinked_folder(work, capsys):
    d, c, s, r = work
    os.symlink(d, d / "alias")
    rc, out, err = run(capsys, "trajectory", s, "--declination", "3", "-o", d / "t.csv",
                       "--las", d / "alias" / "t.csv")
    assert rc == 2
    one_error(err, "t.csv")


def test_an_output_over_the_port(work, capsys):
    d, c, s, r = work
    port = d / "port"
    port.write_bytes(b"")
    rc, out, err = run(capsys, "survey", "--port", port, "--las", port)
    assert rc == 2
    one_error(err, "refusing to write")


# ------------------------------------------------------------ PNGs into a folder
def test_plot_folder_symlink_to_an_input(tmp_path, capsys):
    """A symlink inside the output folder named like a figure points at the
    calibration run: the figure is refused, the run kept."""
    from inclino.benchmarks import calibration as bench
    from inclino.formats import dataset
    from inclino.calib import fit

    ds = bench.emulated_run(bench.bench_probe(linear=True), bench.calibration_poses(), seed=5)
    run_csv = tmp_path / "run.csv"
    dataset.write_raw(str(run_csv), ds)
    cal, _ = fit(ds, "li2021")
    cal_json = tmp_path / "cal.json"
    cal.save(str(cal_json))
    out = tmp_path / "figs"
    out.mkdir()
    assert cli.main(["plot", "--run", str(run_csv), "--cal", str(cal_json), "-o", str(tmp_path / "probe")]) == 0
    names = sorted(os.listdir(tmp_path / "probe"))
    capsys.readouterr()
    assert names
    os.symlink(run_csv, out / names[0])
    before = digest(run_csv)
    rc, o, err = run(capsys, "plot", "--run", run_csv, "--cal", cal_json, "-o", out)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(run_csv) == before and os.path.islink(out / names[0])


def test_diagnose_plot_folder_symlink_to_an_input(tmp_path, capsys):
    from inclino.benchmarks import calibration as bench
    from inclino.formats import dataset

    ds = bench.emulated_run(bench.bench_probe(linear=True), bench.calibration_poses(), seed=6)
    run_csv = tmp_path / "run.csv"
    dataset.write_raw(str(run_csv), ds)
    probe_dir = tmp_path / "probe"
    assert cli.main(["diagnose", str(run_csv), "--effects", "field-drift", "--plot", str(probe_dir)]) == 0
    names = sorted(n for n in os.listdir(probe_dir) if n.endswith(".png"))
    capsys.readouterr()
    assert names
    out = tmp_path / "figs"
    out.mkdir()
    for n in names:
        os.symlink(run_csv, out / n)
    before = digest(run_csv)
    rc, o, err = run(capsys, "diagnose", run_csv, "--effects", "field-drift", "--plot", out)
    assert rc == 2
    one_error(err, "refusing to write")
    assert digest(run_csv) == before
