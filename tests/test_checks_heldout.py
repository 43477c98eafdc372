"""Checks before any fit on logs unlike the corpus's, as held-out public logs
showed them (docs/dataset.md, "Checks before any fit"): a unit named against
the unit the description declared, a magnetometer turned about one axis (its
readings on a circle, which lies on many spheres), a sensor that hardly tilts
(a mirrored axis moves the dip little), a magnetometer sampled slower than the
accelerometer and held between its updates, and the gravity sign that no dip
checks."""
from pathlib import Path

import numpy as np

from inclino import checks
from inclino.calib.ellipsoid import sphere
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
CK = REAL / "ck_acc_mag"


def _ck(toml_text):
    return importlog.import_log(str(CK / "acc_mag_log.csv"), sensor.from_toml(toml_text))[0]


def test_a_unit_is_named_against_the_declared_unit():
    # the CK log is in g and gauss; declared m/s2 and uT the readings are 0.1 g and 400 nT: they look like g, gauss
    text = (CK / "sensor.toml").read_text()
    rep = checks.run(_ck(text.replace('unit = "g"', 'unit = "m/s2"', 1)))
    (f,) = [f for f in rep.findings if f.check == "units" and f.level == "error"]
    assert "look like g," in f.message and "not m/s2" in f.message
    rep = checks.run(_ck(text.replace('unit = "G"', 'unit = "uT"', 1)))
    (f,) = [f for f in rep.findings if f.check == "units" and f.level == "error"]
    assert "look like gauss" in f.message and "not uT" in f.message


def _flat_log(n=6000, seed=3, tilt_deg=20.0, hold=1, mirror=None, shift=0):
    """A sensor on a desk: turned about the vertical through every heading,
    tilted a few degrees, with a MEMS part's offsets and noise; dip 65 deg,
    both triads in one right-handed frame (canonical: +1 g on the axis down)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    smooth = lambda s: np.convolve(rng.normal(0, 1, n + 200), np.ones(200) / 200, "same")[100:n + 100] * s
    psi = 2 * np.pi * t / 1500.0 + smooth(3.0)
    th, ph = np.radians(tilt_deg) * smooth(14.0), np.radians(tilt_deg) * smooth(14.0)
    c, s_ = np.cos, np.sin
    R = np.empty((n, 3, 3))  # body -> world (NED): yaw psi, pitch th, roll ph
    R[:, 0, 0], R[:, 0, 1], R[:, 0, 2] = c(psi) * c(th), c(psi) * s_(th) * s_(ph) - s_(psi) * c(ph), c(psi) * s_(th) * c(ph) + s_(psi) * s_(ph)
    R[:, 1, 0], R[:, 1, 1], R[:, 1, 2] = s_(psi) * c(th), s_(psi) * s_(th) * s_(ph) + c(psi) * c(ph), s_(psi) * s_(th) * c(ph) - c(psi) * s_(ph)
    R[:, 2, 0], R[:, 2, 1], R[:, 2, 2] = -s_(th), c(th) * s_(ph), c(th) * c(ph)
    dip = np.radians(65.0)
    g = np.einsum("nji,j->ni", R, [0.0, 0.0, 1.0])
    b = np.einsum("nji,j->ni", R, 48_000.0 * np.array([np.cos(dip), 0.0, np.sin(dip)]))
    acc = g * (1 + rng.normal(0, 0.01, 3)) + rng.normal(0, 0.02, 3) + rng.normal(0, 0.002, (n, 3))
    mag = b * (1 + rng.normal(0, 0.02, 3)) + rng.normal(0, 1500.0, 3) + rng.normal(0, 100.0, (n, 3))
    if hold > 1:
        mag = mag[(t // hold) * hold]  # sampled once a hold, repeated in between
    if mirror is not None:
        mag[:, mirror] = -mag[:, mirror]
    if shift > 0:
        acc, mag = acc[shift:], mag[:n - shift]
    cols = {k: v for k, v in zip(dataset.ACC_COLS + dataset.MAG_COLS, np.column_stack([acc, mag]).T)}
    return dataset.RawDataset(cols, {})


def _level(rep, check, level):
    return [f for f in rep.findings if f.check == check and f.level == level]


def test_a_mirrored_axis_of_a_sensor_that_hardly_tilts_is_a_warning():
    clean = checks.run(_flat_log(tilt_deg=0.5))
    assert not clean.errors and not clean.warnings
    assert _level(clean, "handedness", "note")  # checked on little, and said so
    rep = checks.run(_flat_log(tilt_deg=0.5, mirror=1))
    (f,) = _level(rep, "handedness", "warning")
    assert "y = -my" in f.message


def test_a_held_magnetometer_is_not_paired_to_a_row():
    for shift in (0, 1):
        rep = checks.run(_flat_log(tilt_deg=20.0, hold=5, shift=shift))
        assert not rep.errors and not rep.warnings
        (f,) = _level(rep, "row-alignment", "note")
        assert "cannot be checked to a row" in f.message and "every 5.0 rows" in f.message


def test_the_gravity_sign_without_a_dip_is_said_unchecked():
    rep = checks.run(_flat_log(tilt_deg=20.0))
    (f,) = _level(rep, "dip-sign", "note")
    assert "+65" in f.message or "+64" in f.message or "+66" in f.message


def test_a_circle_of_readings_determines_no_sphere():
    # a compass turned on a table: the horizontal field (20 uT) on a circle, the vertical part and offsets constant
    rng = np.random.default_rng(1)
    a = np.linspace(0, 6 * np.pi, 400)
    v = np.column_stack([20_000 * np.cos(a) - 40_000, 20_000 * np.sin(a) + 3_000, np.full(400, 55_000.0)])
    assert sphere(v + rng.normal(0, 300.0, v.shape)) is None
