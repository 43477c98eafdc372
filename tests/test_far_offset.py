"""A hard-iron offset larger than the field (a phone's magnetometer reads
~13 times the field off): the readings are fitted less their mean
(calib.ellipsoid.far_mean), so a constant added to a log changes neither
its holds nor its calibration.  Fitted as logged, the quadric's columns far
from the origin were nearly collinear and the holds turned by raw
directions that barely turn: QMC5883L's hand-turned log with 13 times
its readings' radius added was refused as "too few orientations"."""
from pathlib import Path

import numpy as np
import pytest

from inclino import calib, holds
from inclino.calib.ellipsoid import determined, ellipsoid_start, far_mean
from inclino.formats import importlog, sensor
from inclino.formats.dataset import RawDataset

REAL = Path(__file__).parent / "data" / "real" / "qmc5883l"
MAG = ("mx_nT", "my_nT", "mz_nT")


@pytest.fixture(scope="module")
def qmc():
    return importlog.import_log(str(REAL / "filtered_raw_data.csv"), sensor.load(str(REAL / "sensor.toml")))[0]


def _plus(ds, offset):
    cols = dict(ds.columns)
    for k, o in zip(MAG, offset):
        cols[k] = np.asarray(cols[k], float) + o
    return RawDataset(cols, dict(ds.meta))


def _offset(ds, radii):
    """radii times the radius of the sphere the log's readings lie on (10 440 nT: the
    QMC's lsb leaves it at 45 % of the site's field), along a unit vector"""
    from inclino.calib.ellipsoid import sphere

    return radii * sphere(np.asarray(ds.mag, float))[1] * np.array([0.6, -0.64, 0.48])


def test_a_far_offset_leaves_the_ellipsoid_as_it_is(qmc):
    F = float(qmc.meta["field_nT"])
    v = np.asarray(qmc.mag, float)[::10]
    o = _offset(qmc, 13.0)
    assert np.linalg.norm(far_mean(v + o, F)) > 5 * F and not np.any(far_mean(v - v.mean(0), F))
    assert determined(v + o, F)
    M0, b0 = ellipsoid_start(v - v.mean(0), F)
    M1, b1 = ellipsoid_start(v + o, F)
    assert np.allclose(M1, M0, rtol=1e-6, atol=1e-9 * np.abs(M0).max())
    assert np.allclose(b1 - (o + v.mean(0)), b0, atol=1e-6 * F)


def test_a_far_offset_changes_neither_the_holds_nor_the_calibration(qmc):
    """The log less its mean (within the field of the origin: fitted as
    logged) and the log 13 of its radii off: the same holds, the same |b|
    RMS."""
    near = _plus(qmc, -np.asarray(qmc.mag, float).mean(0))
    far = _plus(near, _offset(qmc, 13.0))
    h0, h1 = holds.find(near), holds.find(far)
    assert h0.count == h1.count and np.array_equal(h0.labels, h1.labels)
    reps = [calib.fit(d)[1] for d in (near, far)]
    rms = [r.to_dict()["residuals"]["mag_norm_rms_nT"] for r in reps]
    assert abs(rms[1] / rms[0] - 1.0) < 0.01, rms
    assert reps[0].to_dict()["rows_used"] == reps[1].to_dict()["rows_used"]


def test_an_accelerometer_offset_of_half_a_g_leaves_its_holds_determining():
    """An MPU-9250 at +-16 g read 0.65 g off: the holds' leverage was taken
    from the raw directions, which an offset that large bunches (68 holds
    over the whole sphere read 0.84 and were not fitted alone; every row
    was, moving ones too, and found no ellipsoid).  From the centre of the
    sphere through the holds' means it stays as the log less the offset
    reads.  Here the MPU-6050 step-and-hold session (tedaldi), offsets
    added."""
    root = Path(__file__).parent / "data" / "real" / "mpu6050_tedaldi"
    ds = importlog.import_log(str(root / "example_data_calibration.csv"), sensor.load(str(root / "sensor.toml")))[0]

    def plus(o):
        cols = dict(ds.columns)
        for k, v in zip(("ax_g", "ay_g", "az_g"), o):
            cols[k] = np.asarray(cols[k], float) + v
        return RawDataset(cols, dict(ds.meta))

    h0 = holds.find(ds)
    lev0 = holds.leverage(ds, h0, ("acc",))
    for o in ((-0.01, -0.42, -0.5), (0.3, -0.3, 0.4), (-0.5, 0.5, 0.3)):
        d = plus(o)
        h = holds.find(d)
        assert abs(holds.leverage(d, h, ("acc",)) - lev0) < 0.12
        assert holds.determining(d, ("acc",)) is not None


def test_readings_that_do_not_turn_are_not_taken_less_their_mean(rng):
    """A sensor held still (an LSM303 on a robot: its magnetometer 1.45
    fields from the origin, within a degree) has its mean where its readings
    are; less it they were noise read as directions, and a still log was
    said to move between 43 holds.  The far mean is taken only where the
    readings turn."""
    still = np.array([60_000.0, 20_000.0, -35_000.0]) + rng.normal(scale=300.0, size=(500, 3))
    assert not far_mean(still, 50_000.0).any()
    u = rng.normal(size=(500, 3))
    turned = 13 * 50_000.0 * np.array([0.6, 0.0, 0.8]) + 50_000.0 * u / np.linalg.norm(u, axis=1, keepdims=True)
    assert np.allclose(far_mean(turned, 50_000.0), turned.mean(0))


def test_the_accelerometers_holds_are_read_as_logged(rng):
    """An accelerometer's offsets never come near 1 g: readings held near
    z up with a 1.08 scale lie just beyond 1 g, and taken less their mean
    the holds' directions were noise (calibrate asked for holds "near +y" on
    a log whose z never left the vertical)."""
    acc = np.array([0.02, -0.01, 1.08]) + rng.normal(scale=0.01, size=(400, 3))
    ds = RawDataset({"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2]}, {})
    assert np.array_equal(holds._centred(ds, "acc"), ds.acc)
