"""`inclino diagnose DATA.csv [--json] [--plot DIR]` through the command's
main(): output shapes, PNGs, and bad input as one plain error line with exit
status 2 (never a traceback); `python -m inclino.cli.bench_diagnose` on a tiny
seeded set."""
import json

import numpy as np
import pytest

from inclino.cli import main
from inclino.formats.dataset import RawDataset, write_raw
from inclino.benchmarks import diagnose as dbench
from inclino.cli import bench_diagnose as cli_bench_diagnose
from inclino.diagnose import plans
from inclino.model.world import Trajectory


def _write(tmp_path, ds, name="run.csv"):
    p = tmp_path / name
    write_raw(str(p), ds)
    return str(p)


def _run(capsys, *argv):
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def _one_error_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("inclino: error: "), err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture(scope="module")
def tb_dataset():
    p = plans.hide(plans.PROBE, "temperature-bias", "mag", "y", 0.3)
    return plans.generate(p, plans.oven_plan(seed=5), 5)


def test_json_output_has_exactly_the_issue_keys(tmp_path, capsys, tb_dataset):
    rc, out, err = _run(capsys, "diagnose", _write(tmp_path, tb_dataset), "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert list(d) == ["baseline", "effects", "contradicted", "confounded", "unexplained", "checks", "calibrate",
                       "motion", "pairing", "conclusion"]
    (e,) = d["effects"]
    assert (e["name"], e["sensor"], e["axis"], e["units"]) == ("temperature-bias", "mag", "y", "nT/degC")
    assert abs(e["estimate"] - 0.3) <= 3 * e["stderr"]
    assert d["unexplained"] is False


def test_text_report_and_plots(tmp_path, capsys, tb_dataset):
    out_dir = tmp_path / "plots"
    rc, out, err = _run(capsys, "diagnose", _write(tmp_path, tb_dataset), "--plot", str(out_dir))
    assert rc == 0, err
    assert "effect: temperature-bias (mag y)" in out
    assert "unexplained: no" in out
    last = out.strip().splitlines()[-1]  # the conclusion, with the figure that decided it
    assert last.startswith("conclusion: FAIL: the 12-parameter model misses temperature-bias (mag y, p = ")
    assert "azimuth RMS " in last and " -> " in last
    assert "not testable: sample-skew" in out  # static data: said, not guessed
    for name in ("temperature-bias_mag_y.png", "baseline.png"):
        data = (out_dir / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def test_null_dataset_text_says_none(tmp_path, capsys):
    ds = plans.generate(plans.PROBE, plans.rotation_plan(), 21)
    rc, out, err = _run(capsys, "diagnose", _write(tmp_path, ds))
    assert rc == 0, err
    assert "effects found: none" in out and "(continuous)" in out
    last = out.strip().splitlines()[-1]
    assert last.startswith("conclusion: PASS: the 12-parameter model leaves nothing to name: no effect at "
                           "alpha = 0.01, no unexplained structure (residual RMS")


def test_too_few_poses(tmp_path, capsys, tb_dataset):
    small = RawDataset({k: v[:10] for k, v in tb_dataset.columns.items()}, dict(tb_dataset.meta))
    rc, _, err = _run(capsys, "diagnose", _write(tmp_path, small))
    assert rc == 2
    assert "too few poses" in _one_error_line(err)


def test_no_pose_columns(tmp_path, capsys, tb_dataset):
    """Two of the three pose columns: not a pose-based diagnosis (the
    missing axis is unknown), the pose-free one, which says which column is
    missing and ends with its own conclusion."""
    cols = {k: v for k, v in tb_dataset.columns.items() if k != "azi_deg"}
    rc, out, err = _run(capsys, "diagnose", _write(tmp_path, RawDataset(cols, dict(tb_dataset.meta))))
    assert rc == 0, err
    assert "poses incomplete: no azi_deg column" in out
    assert "needs the poses" in out
    assert out.strip().splitlines()[-1].startswith("conclusion: ")
    assert "the pose-free model" in out.strip().splitlines()[-1]


def test_temperature_effect_asked_of_a_constant_temperature(tmp_path, capsys):
    plan = dict(plans.oven_plan(seed=2), temp_c=np.full(288, 24.0))
    ds = plans.generate(plans.PROBE, plan, 2)
    rc, _, err = _run(capsys, "diagnose", _write(tmp_path, ds), "--effects", "temperature-bias")
    assert rc == 2
    line = _one_error_line(err)
    assert "temperature-bias" in line and "temperature never changes" in line
    # not asked about: the other effects are tested and the temperature ones reported as not testable
    rc, out, err = _run(capsys, "diagnose", _write(tmp_path, ds))
    assert rc == 0 and "not testable: temperature-bias" in out


def test_skew_asked_of_a_one_way_rotation_cannot_be_separated(tmp_path, capsys):
    """Turning the toolface always the same way at one rate, a fluxgate
    sampled late is a fixed rotation about the tool axis: the 12-parameter
    misalignment absorbs it and no skew can be estimated."""
    key = [(0.0, 30.0, 10.0, 0.0)]
    t, ts = 0.0, []
    for inc, azi in ((30, 10), (60, 100), (90, 200), (120, 300), (150, 50)):
        t += 2.0
        key.append((t, inc, azi, 0.0))
        t0, t = t, t + 4.0
        key.append((t, inc, azi, 360.0))
        ts.append(t0 + np.arange(1, 40) / 10.0)
    traj = Trajectory(*(np.array(c) for c in zip(*key)))
    plan = {"kind": "continuous", "trajectory": traj, "t_s": np.concatenate(ts), "temp_c": 25.0}
    ds = plans.generate(plans.hide(plans.PROBE, "sample-skew", "mag", "xyz", 2e-3), plan, 3, sigma_pose_deg=0.0)
    rc, _, err = _run(capsys, "diagnose", _write(tmp_path, ds), "--effects", "sample-skew")
    assert rc == 2
    assert "cannot be told from the 12-parameter baseline" in _one_error_line(err)


def test_poses_that_cannot_separate_the_baseline(tmp_path, capsys):
    """Every pose horizontal: gravity never has a z component, so the
    accelerometer's z row cannot be fitted."""
    rng = np.random.default_rng(0)
    n = 60
    plan = {"kind": "static", "inc": np.full(n, 90.0), "azi": rng.uniform(0, 360, n), "tf": rng.uniform(0, 360, n),
            "t_s": np.arange(n) * 60.0, "temp_c": 25 + 20 * np.sin(np.arange(n) / 7)}
    ds = plans.generate(plans.PROBE, plan, 4)
    rc, _, err = _run(capsys, "diagnose", _write(tmp_path, ds))
    assert rc == 2
    line = _one_error_line(err)
    assert "cannot separate the baseline" in line
    # the message names what the poses leave undetermined: with gravity never along body z, the accelerometer's
    # z offset and gain (the pose fit's own check, calib.triad.poses_span: the poses' gravity on one plane)
    assert "undetermined" in line and "accelerometer" in line and "z offset and the gain on z" in line


def test_unknown_effect_and_missing_input(tmp_path, capsys, tb_dataset):
    rc, _, err = _run(capsys, "diagnose", _write(tmp_path, tb_dataset), "--effects", "gremlins")
    assert rc == 2 and "unknown effect" in _one_error_line(err)
    rc, _, err = _run(capsys, "diagnose")
    assert rc == 2 and "needs a raw dataset" in _one_error_line(err)
    rc, _, err = _run(capsys, "diagnose", str(tmp_path / "absent.csv"))
    assert rc == 2 and "cannot read" in _one_error_line(err)


@pytest.mark.heavy
def test_bench_module_quick_set(capsys):
    """The quick bench (a size sweep at z = 2, 6, 30, 270 with one dataset
    per size and effect, every other one at z >= 6 spiked, two nulls):
    the report's shape, every effect found at z >= 6, no error exit; it is
    too small for the targets (nulls < 200), so it exits 1."""
    rc = cli_bench_diagnose.diagnose_main(["--json", "--quick", "--nulls", "2", "--pairs", "0", "--seed", "77"])
    d = json.loads(capsys.readouterr().out)
    assert set(d["sweep"]["effects"]) == set(dbench.core.EFFECT_NAMES)
    assert d["sweep"]["z"] == list(dbench.Z_SWEEP_QUICK)
    for name, e in d["sweep"]["effects"].items():
        assert e["min_rate_z_ge_6"] == 1.0, (name, e)
        assert e["rate_outliers_z_ge_6"] == 1.0, (name, e)
        # the crossing lies below the first swept size at which detection is required (6; a rig field's 12, with
        # 12-15 columns, is first reached at 30 on this grid: one dataset per size puts its z50 between 6 and 30)
        first_required = min(z for z in d["sweep"]["z"] if z >= e["z_detect_min"])
        assert e["z50"] is not None and 2.0 <= e["z50"] <= first_required
    assert d["null"]["datasets"] == 2 and d["errors"] == []
    assert d["met"]["nulls"] is False and d["met"]["no_errors"] is True and rc == 1
    # the real-data section (quick: SAP6's six runs): injected kinds, resampled untouched logs, the held-out
    # prediction per log and invariant, each a figure measured on the real readings
    real = d["real_data"]
    assert real["datasets"] == [f"sap6/{n}" for n in ("BB", "CF", "FG", "HC", "IB", "JG")]
    assert set(real["injected"]) == {"temperature-bias", "scale-nonlinearity", "rig-field", "field-drift"}
    # each injection counted, or listed as one the log cannot show at that size
    assert all(v["cases"] + len(v["not_testable"]) == 12 for v in real["injected"].values())
    assert real["nulls"]["resamplings"] == 72
    assert set(real["prediction"]) == set(real["datasets"])
    for p in real["prediction"].values():
        assert set(p) == {"|g|", "|b|", "dip"}
        assert all(v["predicted_heldout_rms"] > 0 and v["achieved_heldout_rms"] > 0 for v in p.values())
    assert {"real_injected_found", "real_false_alarms", "real_prediction"} <= set(d["met"])


def test_bench_module_real_only_takes_its_seed_and_sizes(capsys, monkeypatch):
    """--real-only --seed/--per-size/--nulls reach the real-data section as
    its first seed, injections per effect and log, and resamplings per log
    (the figures docs/diagnose.md quotes are printed by these options);
    without them: seed 2024, 2 and 12."""
    from inclino.benchmarks import diagnose_real

    calls = []

    def fake(**k):
        calls.append(k)
        return diagnose_real.RealDiagnoseBench(note="stub", passed=True)
    monkeypatch.setattr(diagnose_real, "bench_real", fake)
    assert cli_bench_diagnose.diagnose_main(["--real-only", "--seed", "777", "--per-size", "4", "--nulls", "40"]) == 0
    assert cli_bench_diagnose.diagnose_main(["--real-only", "--json"]) == 0
    assert cli_bench_diagnose.diagnose_main(["--real-only", "--logs", "mpu6050, sap6/BB"]) == 0
    assert calls == [dict(seeds=4, resamplings=40, seed0=777, quick=False, logs=None),
                     dict(seeds=2, resamplings=12, seed0=2024, quick=False, logs=None),
                     dict(seeds=2, resamplings=12, seed0=2024, quick=False, logs=["mpu6050", "sap6/BB"])]
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        cli_bench_diagnose.diagnose_main(["--real-only", "--nulls", "-1"])
    assert e.value.code == 2 and ">= 0" in capsys.readouterr().err


def test_bench_real_logs_keep_their_draws(monkeypatch):
    """--logs picks corpus logs by the start of their names, each keeping
    its place in the corpus (its seeds): the MPU-6050 alone gets the same
    injections as in the whole section.  A name no log starts with is
    exit 2."""
    import numpy as np

    from inclino.benchmarks import diagnose_real

    data = diagnose_real.corpus()
    if not data:
        pytest.skip("the corpus is not in this checkout")
    i = [n for n, _ in data].index("mpu6050_tedaldi")
    want = [diagnose_real.inject(data[i][1], kind, np.random.default_rng([2024, i, 0, len(kind)]))[1:]
            for kind in ("temperature-bias", "scale-nonlinearity")]
    got, inject = [], diagnose_real.inject

    def recorded(ds, kind, rng, key=None, detail=False):
        out = inject(ds, kind, rng, key, detail)
        if out is not None:
            got.append(out[1:3])
        return out
    monkeypatch.setattr(diagnose_real, "inject", recorded)
    one = diagnose_real.bench_real(seeds=1, resamplings=0, logs=["mpu6050"])
    assert one.datasets == ["mpu6050_tedaldi"]
    assert got == want
    assert not one.injected["rig-field"]["cases"] and "no case" in " ".join(one.lines())
    with pytest.raises(SystemExit) as e:
        cli_bench_diagnose.diagnose_main(["--real-only", "--logs", "nosuch"])
    assert e.value.code == 2


def test_bench_module_near_limit_rates(capsys):
    """--near-limit: per effect, plan and size, the misses with what was
    named instead; below the threshold (z = 2) nothing is found, far above
    it (z = 30) everything is; a zero count carries its 95 % bound."""
    rc = cli_bench_diagnose.diagnose_main(["--json", "--near-limit", "2,30", "--draws", "2", "--effects",
                                           "temperature-bias", "--seed", "91"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["z"] == [2.0, 30.0] and list(d["effects"]) == ["temperature-bias"]
    (low, high), = d["effects"]["temperature-bias"].values()
    assert low["misses"] == 2 and low["rate"] == 1.0 and len(low["missed"]) == 2 and low["rate_upper_95"] is None
    assert all(m["named"] == [] and m["sensor"] in ("acc", "mag") for m in low["missed"])
    assert high["misses"] == 0 and high["missed"] == [] and high["rate_upper_95"] == 1.0
    for bad, why in ((["--near-limit", "x"], "comma-separated"), (["--near-limit", "6", "--effects", "nope"],
                                                                   "unknown effect")):
        with pytest.raises(SystemExit) as e:
            cli_bench_diagnose.diagnose_main(bad)
        assert e.value.code == 2 and why in capsys.readouterr().err


def test_bench_module_runs_as_a_module_without_warnings():
    """`python -m inclino.cli.bench_diagnose` is not imported by the CLI
    package first (runpy would warn that it is run twice)."""
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-m", "inclino.cli.bench_diagnose", "--help"], capture_output=True, text=True)
    assert p.returncode == 0 and "--near-limit" in p.stdout and p.stderr == "", p.stderr
