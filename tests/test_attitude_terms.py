"""`inclino attitude --cal CAL.json` applies every term of the calibration
in every engine: the temperature terms from each row's temp_c (or
--at-temperature), none skipped silently, a calibration with terms on data
without temp_c refused (exit 2)."""
import json

import numpy as np
import pytest

from inclino.benchmarks.temperature import _tempcos, typical_block
from inclino.cli import main
from inclino.engines import reference as ref
from inclino.formats import dataset
from inclino.formats.calfile import Calibration
from inclino.model import effects as fx
from inclino.model.typical_probe import _raw_for, typical_calibration

TEMPS = (-5.0, 25.0, 55.0)


@pytest.fixture(scope="module")
def oven(tmp_path_factory):
    """A probe whose sensors drift with temperature as the block says, read
    on a grid at -5, 25 and 55 degC; its calibration with the terms, and the
    same M, b without them."""
    d = tmp_path_factory.mktemp("oven")
    base = typical_calibration()
    block = typical_block()
    cal = Calibration(acc_m=base.acc_m, acc_b=base.acc_b, mag_m=base.mag_m, mag_b=base.mag_b, method="joint",
                      temperature=dict(block, applied_by_firmware=True))
    plain = Calibration(acc_m=base.acc_m, acc_b=base.acc_b, mag_m=base.mag_m, mag_b=base.mag_b, method="joint")
    I, A, T = (g.ravel() for g in np.meshgrid(np.arange(10.0, 91.0, 20.0), np.arange(0.0, 360.0, 45.0),
                                              np.array([0.0, 120.0, 240.0]), indexing="ij"))
    g_true, b_true = ref.body_vectors(I, A, T, 50000.0, 60.0)
    ga, bm = _raw_for(cal, g_true, b_true)
    cols = {k: [] for k in ("inc_deg", "azi_deg", "tf_deg", "temp_c") + dataset.SENSOR_COLS}
    for t in TEMPS:
        raw = {}
        for tri, r0, b in (("acc", ga, cal.acc_b), ("mag", bm, cal.mag_b)):
            bt, st = _tempcos(block, tri)
            raw[tri] = fx.from_reference_temperature(r0, t, b, bt, st)
        for k, v in zip(("inc_deg", "azi_deg", "tf_deg"), (I, A, T)):
            cols[k].append(v)
        cols["temp_c"].append(np.full(len(I), t))
        for i, c in enumerate(dataset.ACC_COLS):
            cols[c].append(raw["acc"][:, i])
        for i, c in enumerate(dataset.MAG_COLS):
            cols[c].append(raw["mag"][:, i])
    ds = dataset.RawDataset({k: np.concatenate(v) for k, v in cols.items()},
                            {"field_nT": 50000.0, "dip_deg": 60.0})
    run = d / "oven.csv"
    dataset.write_raw(str(run), ds)
    cal.save(str(d / "cal.json"))
    plain.save(str(d / "plain.json"))
    return d, ds


def _errors(ds, path, sel):
    a = np.genfromtxt(path, delimiter=",", names=True)
    da = ref.angle_diff(a["azi_deg"][sel], ds.columns["azi_deg"][sel])
    di = a["inc_deg"][sel] - ds.columns["inc_deg"][sel]
    return float(np.sqrt(np.mean(da ** 2))), float(np.sqrt(np.mean(di ** 2)))


@pytest.mark.parametrize("engine", ["firmware", "golden", "reference"])
def test_every_engine_applies_the_temperature_terms(oven, engine):
    d, ds = oven
    with_, without = d / f"w_{engine}.csv", d / f"wo_{engine}.csv"
    assert main(["attitude", str(d / "oven.csv"), "--cal", str(d / "cal.json"), "--engine", engine,
                 "-o", str(with_)]) == 0
    assert main(["attitude", str(d / "oven.csv"), "--cal", str(d / "plain.json"), "--engine", engine,
                 "-o", str(without)]) == 0
    for t in TEMPS:
        sel = ds.columns["temp_c"] == t
        azi, inc = _errors(ds, with_, sel)
        azi0, inc0 = _errors(ds, without, sel)
        # with the terms: the correction's own fixed-point loss (docs/fixed-point.md), at every temperature
        assert azi < 0.01 and inc < 0.005, (engine, t, azi, inc)
        if t != 25.0:  # without them the drift is there: the terms were applied, not skipped
            assert azi0 > 10 * max(azi, 0.001), (engine, t, azi0, azi)


def test_terms_without_temp_c_are_refused_unless_the_temperature_is_given(oven, capsys):
    d, ds = oven
    cols = {k: v for k, v in ds.columns.items() if k != "temp_c"}
    sel = ds.columns["temp_c"] == 55.0
    hot = dataset.RawDataset({k: v[sel] for k, v in cols.items()}, dict(ds.meta))
    run = d / "hot_no_temp.csv"
    dataset.write_raw(str(run), hot)
    out = d / "hot.csv"
    assert main(["attitude", str(run), "--cal", str(d / "cal.json"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--at-temperature" in err and err.count("\n") == 1 and not out.exists()
    assert main(["attitude", str(run), "--cal", str(d / "cal.json"), "--at-temperature", "55", "-o", str(out)]) == 0
    azi, inc = _errors(hot, out, np.ones(len(hot), bool))
    assert azi < 0.01 and inc < 0.005


def test_at_temperature_out_of_range_is_bad_input(oven, capsys):
    d, _ = oven
    assert main(["attitude", str(d / "oven.csv"), "--cal", str(d / "cal.json"), "--at-temperature", "1e9",
                 "-o", str(d / "x.csv")]) == 2


def test_temperatures_beyond_the_calibration_run_are_said_to_be_extrapolated(oven, capsys):
    """85 and 120 degC on a calibration fitted from -5 to 55 degC were applied
    without a word; within 5 degC of the run, nothing is said."""
    d, ds = oven
    span = json.loads((d / "cal.json").read_text())["temperature"]["span_c"]
    out = d / "x.csv"
    assert main(["attitude", str(d / "oven.csv"), "--cal", str(d / "cal.json"), "--at-temperature",
                 f"{span[1] + 4.0:g}", "-o", str(out)]) == 0
    assert "extrapolated" not in capsys.readouterr().err
    assert main(["attitude", str(d / "oven.csv"), "--cal", str(d / "cal.json"), "--at-temperature", "85",
                 "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"warning: --at-temperature 85 degC is outside the calibration run's {span[0]:.1f} to {span[1]:.1f} degC" \
        in err and "extrapolated" in err, err
    cols = {k: v.copy() for k, v in ds.columns.items()}
    cols["temp_c"][:10] = 120.0
    hot = d / "hot_rows.csv"
    dataset.write_raw(str(hot), dataset.RawDataset(cols, dict(ds.meta)))
    assert main(["attitude", str(hot), "--cal", str(d / "cal.json"), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"warning: 10 of {len(ds)} row(s) at temperatures outside the calibration run's" in err, err
