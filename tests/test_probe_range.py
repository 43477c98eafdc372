"""A reading beyond the probe's own range (the ADIS16210's +-1.7 g, the
fluxgate's +-100 000 nT: docs/conventions.md) in a dataset of the probe that
declares no range is a row the sensor cannot give: the checks name it and
the fit leaves it out, as a declared range's saturated rows (checks.
_saturation).  One garbled row (ax_g = 25 among 359 rows of 1 g) had dropped
an oven run's temperature terms as "not what the model lacks"; at 1e10 it
was refused as a unit declared wrong."""
import numpy as np
import pytest

from inclino import checks
from inclino.calib import fit
from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset


def _run(seed=4, n=200):
    """n static rows at random poses of a probe with 1 % scale and cross-axis
    errors (docs/conventions.md: the accelerometer reads C[:, 2], the field
    is F (cos dip, 0, sin dip) in NED turned by C)."""
    rng = np.random.default_rng(seed)
    inc, azi, tf = rng.uniform(5, 175, n), rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    C = ref.pose_matrix(inc, azi, tf)
    dip, F = np.radians(60.0), 48_000.0
    g = C[:, :, 2]
    b = C @ (F * np.array([np.cos(dip), 0.0, np.sin(dip)]))
    A, Am = np.eye(3) + rng.normal(0, 0.01, (3, 3)), np.eye(3) + rng.normal(0, 0.01, (3, 3))
    acc = g @ A.T + rng.normal(0, 0.01, 3) + rng.normal(0, 2e-4, (n, 3))
    mag = b @ Am.T + rng.normal(0, 300, 3) + rng.normal(0, 20, (n, 3))
    cols = {"inc_deg": inc, "azi_deg": azi, "tf_deg": tf, "ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    return RawDataset(cols, {"field_nT": F, "dip_deg": 60.0, "declination_deg": 0.0})


def _with(ds, col, row, value, meta=None):
    cols = {k: v.copy() for k, v in ds.columns.items()}
    cols[col][row] = value
    return RawDataset(cols, {**ds.meta, **(meta or {})})


@pytest.mark.parametrize("col, value", [("ax_g", 25.0), ("ax_g", 1e10), ("mz_nT", 1048575.0)])
def test_a_row_beyond_the_probes_range_is_named_and_left_out(col, value):
    clean = _run()
    ds = _with(clean, col, 31, value)
    rep = checks.run(ds)
    (f,) = [f for f in rep.findings if f.check == "saturation"]
    assert f.level == "warning" and "beyond the" in f.message and "(rows 32)" in f.message
    assert rep.saturated == [31]
    cal, r = fit(ds)
    keep = np.arange(len(clean)) != 31
    cal0, _ = fit(RawDataset({k: v[keep] for k, v in clean.columns.items()}, dict(clean.meta)))
    assert np.allclose(cal.acc_m, cal0.acc_m, atol=1e-9) and np.allclose(cal.mag_b, cal0.mag_b, atol=1e-6)


def test_an_imported_sensor_without_a_declared_range_keeps_its_rows():
    """Another sensor's log (the header's `sensor`): the probe's range is not
    its range, and nothing is left out without a declared one."""
    ds = _with(_run(), "ax_g", 31, 2.5, {"sensor": "a 16 g MEMS part"})
    assert not [f for f in checks.run(ds).findings if f.check == "saturation"]
    ds = _with(ds, "ax_g", 31, 2.5, {"acc_range_g": 2.0})
    assert checks.run(ds).saturated == [31]


def test_every_row_beyond_the_range_is_a_unit_not_a_garbled_row():
    ds = _run()
    cols = dict(ds.columns, ax_g=ds.columns["ax_g"] * 9.80665, ay_g=ds.columns["ay_g"] * 9.80665,
                az_g=ds.columns["az_g"] * 9.80665)
    rep = checks.run(RawDataset(cols, dict(ds.meta)))
    assert not [f for f in rep.findings if f.check == "saturation"]
    assert any(f.check == "units" and f.level == "error" for f in rep.findings)
