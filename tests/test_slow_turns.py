"""A sensor turned slowly and smoothly is moving, not step-and-hold; a
step-and-hold log's drift, hum, quantisation and vibration leave it static.

The logs are drawn here with scipy's rotations, apart from inclino's own
model: gravity 1 g down, a field of 50 000 nT dipping 60 deg, per-triad
scale, offset and cross-axis errors, white noise (1 mg, 100 nT), no noise
declared.  A turn of 0.1-0.3 deg a row moves each axis by 1-3 mg a row,
within 3x the 5 mg bound a MEMS part stays within at rest, and every
10-row window is as still as the next: the log was read as static and cut
into 190-250 "holds" of 11 rows each turning up to 3 deg (holds.find's
window means lag its rows).  The real corpus has two such logs, both
turned by hand: the QMC5883L (50 Hz, 1 691 "holds") and the iPhone
(checks said static)."""
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot, Slerp

from inclino import checks, holds
from inclino.calib import fit
from inclino.formats import importlog, sensor
from inclino.formats.dataset import RawDataset

REAL = Path(__file__).parent / "data" / "real"
DIP = np.radians(60.0)
FIELD = 50_000.0 * np.array([np.cos(DIP), 0.0, -np.sin(DIP)])  # north, down = -z (world z up)


def _tumble(rng, n, deg_per_row, axis=None, wander=0.02):
    """n orientations turning deg_per_row about an axis that wanders
    slowly (fixed: axis given)."""
    ax = np.asarray(axis, float) if axis is not None else rng.normal(size=3)
    ax /= np.linalg.norm(ax)
    out = [Rot.random(random_state=rng) if axis is None else Rot.identity()]
    for _ in range(n - 1):
        if axis is None:
            ax = ax + wander * rng.normal(size=3)
            ax /= np.linalg.norm(ax)
        out.append(Rot.from_rotvec(np.radians(deg_per_row) * ax) * out[-1])
    return Rot.concatenate(out)


def _step_and_hold(rng, n_holds=30, hold_rows=200, move_rows=20):
    keys = Rot.random(n_holds, random_state=rng)
    out = []
    for k in range(n_holds):
        out += [keys[k]] * hold_rows
        if k + 1 < n_holds:
            x = 0.5 - 0.5 * np.cos(np.pi * np.linspace(0, 1, move_rows + 2)[1:-1])
            out += list(Slerp([0, 1], Rot.concatenate([keys[k], keys[k + 1]]))(x))
    return Rot.concatenate(out)


def _log(rng, R, acc_noise=1e-3, mag_noise=100.0, acc_lsb=None, mag_lsb=None, drift=False, hum_nT=0.0,
         vib_g=0.0, rate_hz=100.0):
    """A dataset of the readings at the orientations R (body <- world as
    R.inv()): the accelerometer reads +1 g on an axis pointing up."""
    n = len(R)
    t = np.arange(n) / rate_hz

    def errors(off):
        return (np.eye(3) + np.diag(rng.normal(0, 0.02, 3)) + rng.normal(0, 0.01, (3, 3)) * (1 - np.eye(3)),
                rng.normal(0, off, 3))
    (Ma, ba), (Mm, bm) = errors(0.03), errors(3000.0)
    acc = R.inv().apply([0.0, 0.0, 1.0])
    if vib_g:  # vibration at rest: white acceleration, high-passed by differencing
        v = np.diff(rng.normal(size=(n + 1, 3)), axis=0)
        acc = acc + vib_g * v / v.std()
    acc = acc @ Ma.T + ba + rng.normal(0, acc_noise, (n, 3))
    mag = R.inv().apply(FIELD) @ Mm.T + bm + rng.normal(0, mag_noise, (n, 3))
    if drift:  # a temperature's slow drift over the run: 5 mg, 1 000 nT
        acc += np.outer(np.linspace(0, 1, n), [5e-3, -3.5e-3, 2.5e-3])
        mag += np.outer(np.linspace(0, 1, n), [1000.0, 600.0, -800.0])
    if hum_nT:  # 50 Hz on the magnetometer, aliased by the row rate
        mag += hum_nT * np.sin(2 * np.pi * 50.0 * t[:, None] + rng.uniform(0, 2 * np.pi, 3))
    meta = {}
    if acc_lsb:
        acc, meta["acc_lsb_g"] = np.round(acc / acc_lsb) * acc_lsb, acc_lsb
    if mag_lsb:
        mag, meta["mag_lsb_nT"] = np.round(mag / mag_lsb) * mag_lsb, mag_lsb
    cols = {"t_s": t, **{f"a{c}_g": acc[:, k] for k, c in enumerate("xyz")},
            **{f"m{c}_nT": mag[:, k] for k, c in enumerate("xyz")}}
    return RawDataset(columns=cols, meta=meta)


def _motion_notes(rep):
    return [f.message for f in rep.findings if f.check == "motion"]


@pytest.mark.parametrize("deg_per_row", [0.1, 0.3, 1.0])
def test_a_slow_smooth_turn_is_read_as_moving(deg_per_row):
    """Before: 0.1 and 0.3 deg a row were step-and-hold (193-254 holds,
    every row held) and all three static by the checks, no motion said."""
    rng = np.random.default_rng(11)
    ds = _log(rng, _tumble(rng, 3000, deg_per_row))
    h = holds.find(ds)
    assert not h.step_and_hold and h.rows_held < 0.1 * len(ds), (h.count, h.rows_held)
    rep = checks.run(ds)
    assert rep.static is False
    (note,) = _motion_notes(rep)
    assert "continuous rotation" in note and "within a static sensor's noise" in note, note


def test_a_turn_about_the_vertical_is_no_hold():
    """The accelerometer still, the magnetometer turning 0.3 deg a row (a
    sensor spun slowly about the vertical): the accelerometer's direction
    does not turn, the field's does.  Before: holds of 11 rows, each a
    3 deg turn of the field, the log step-and-hold."""
    rng = np.random.default_rng(12)
    ds = _log(rng, _tumble(rng, 3000, 0.3, axis=[0.0, 0.0, 1.0]))
    h = holds.find(ds)
    assert not h.step_and_hold and h.rows_held < 0.1 * len(ds), (h.count, h.rows_held)
    assert checks.run(ds).static is False


@pytest.mark.parametrize("what", ["plain", "drift", "hum", "quantised", "vibration", "all"])
def test_a_step_and_hold_log_stays_static(what):
    """30 holds of 200 rows: drift, 50 Hz hum (300 nT, 105 rows/s),
    coarse counts (4 mg, 300 nT) and vibration at rest (5 mg) keep it
    static, every hold found."""
    rng = np.random.default_rng(13)
    kw = {"plain": {}, "drift": {"drift": True}, "hum": {"hum_nT": 300.0, "rate_hz": 105.0},
          "quantised": {"acc_lsb": 1 / 256, "mag_lsb": 300.0, "acc_noise": 0.5e-3, "mag_noise": 50.0},
          "vibration": {"vib_g": 5e-3},
          "all": {"drift": True, "hum_nT": 300.0, "rate_hz": 105.0, "acc_lsb": 1 / 1024, "mag_lsb": 150.0}}[what]
    ds = _log(rng, _step_and_hold(rng), **kw)
    h = holds.find(ds)
    assert h.step_and_hold and h.count >= 30 and h.rows_held > 0.85 * len(ds), (h.count, h.rows_held)
    rep = checks.run(ds)
    assert rep.static is True and not any("continuous rotation" in m for m in _motion_notes(rep))


def test_calibrating_a_slow_turn_fits_every_row_not_holds():
    """Calibrate on the 0.3 deg a row turn: before, "a step-and-hold log:
    254 static holds" were fitted and 106 rows left out as read while
    moving (a steady turn has no hand's acceleration to leave out)."""
    rng = np.random.default_rng(11)
    ds = _log(rng, _tumble(rng, 3000, 0.3))
    _, rep = fit(ds, "joint")
    assert not any(n.startswith("holds:") for n in rep.notes), rep.notes
    assert rep.rows_used > 0.98 * len(ds)


def _corpus(log, desc="sensor.toml"):
    d = REAL / log.split("/")[0]
    return importlog.import_log(str(REAL / log), sensor.load(str(d / desc)))[0]


@pytest.mark.parametrize("log", ["qmc5883l/filtered_raw_data.csv",
                                 "iphone_sensor_logger/AccelerometerUncalibrated.csv"])
def test_real_logs_turned_by_hand_are_moving(log):
    """Both turned by hand through many orientations (their SOURCE.md):
    their consecutive rows differ within the noise bound (262 nT a row for
    the QMC5883L, 14 mg for the iPhone), so the checks called them static;
    the QMC5883L's readings were cut into 1 691 holds (80 % of its rows)."""
    ds = _corpus(log)
    rep = checks.run(ds)
    assert rep.static is False
    assert any("continuous rotation" in m for m in _motion_notes(rep)), _motion_notes(rep)
    assert not holds.find(ds).step_and_hold


@pytest.mark.parametrize("log,desc", [("mpu6050_tedaldi/example_data_calibration.csv", "sensor.toml"),
                                      ("xio_fusion/sensor_data.csv", "sensor.toml"),
                                      ("pololu_minimu9/data_polulu.txt", "sensor.toml"),
                                      ("ck_acc_mag/acc_log.csv", "acc_only.toml"),
                                      ("airbrakes_cx5/six_faces.csv", "sensor.toml"),
                                      ("ngimu/sensors.csv", "sensor.toml")])
def test_real_step_and_hold_logs_stay_static(log, desc):
    ds = _corpus(log, desc)
    assert checks.run(ds).static is True
    assert holds.find(ds).step_and_hold
