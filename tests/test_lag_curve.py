"""The triads' row pairing on continuously moving logs: the dip invariant's
lag curve (inclino.checks._lag_curve).  On the hand-tumbled CK log
(neighbouring rows about 1 deg apart, a one-row shift changes the dip's
spread by 2 %) and on an emulated tumble without the real log's dynamic
acceleration: the lag named is the shift made, the unshifted log is not
named, a skew within a row is a note, never a named shift."""
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.formats import dataset, importlog, sensor
from inclino.model import effects as fx
from inclino.model.scenario import generate_raw, load_scenario
from inclino.model.world import Trajectory

REAL = Path(__file__).parent / "data" / "real"
CK = ("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")


def _shifted(ds, k):
    """The magnetometer's rows k behind (its row i + k is the accelerometer's row i's)."""
    c = {key: v.copy() for key, v in ds.columns.items()}
    for m in dataset.MAG_COLS:
        c[m] = np.roll(c[m], k)
    n = len(ds)
    return dataset.RawDataset({key: v[k:] if k > 0 else v[:n + k] for key, v in c.items()}, dict(ds.meta))


def _lag_findings(rep, levels=("error", "warning")):
    return [f for f in rep.findings if f.check == "row-alignment" and f.level in levels]


@pytest.fixture(scope="module")
def ck():
    ds = importlog.import_log(str(REAL / CK[0]), sensor.load(str(REAL / CK[1])))[0]
    return ds, checks.run(ds)


def test_the_unshifted_ck_log_names_no_shift(ck):
    ds, rep = ck
    assert rep.lag_rows == 0 and not _lag_findings(rep, ("error", "warning", "note")), rep.lines()
    c = rep.lag_curve
    # the whole log and each half on its own: nearest whole row 0
    assert round(c["lag_rows"]) == 0 and all(round(h) == 0 for h in c["halves_rows"]), c


@pytest.mark.parametrize("k", [2, -2, 3, -3])
def test_a_shift_of_two_or_three_rows_of_the_ck_log_is_named(ck, k):
    rep = checks.run(_shifted(ck[0], k))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message
    # the named lag survives a second view: each half of the log finds it on its own
    assert all(round(h) == k for h in rep.lag_curve["halves_rows"]), rep.lag_curve


@pytest.mark.parametrize("k", [1, -1])
def test_a_one_row_shift_of_the_ck_log_moves_the_lag_curve_by_that_row(ck, k):
    """The curve follows the shift to a fraction of a row; on this log the
    fraction is within its own scatter of half a row (the accelerometer sees
    tens of mg of the hand's acceleration), so the shift is a note naming the
    possible lag, and never a wrong lag."""
    rep = checks.run(_shifted(ck[0], k))
    assert abs(rep.lag_curve["lag_rows"] - ck[1].lag_curve["lag_rows"] - k) < 0.2, rep.lag_curve
    assert rep.lag_rows in (0, k)
    if rep.lag_rows == 0:
        (note,) = _lag_findings(rep, ("note",))
        assert note.figures["lag_rows_possible"] == k and "not named" in note.message


def test_the_lag_named_on_the_ck_log_is_the_lag_that_fixes_its_import(tmp_path):
    lines = (REAL / CK[0]).read_text().splitlines()
    head, body = lines[0], [r.split(",") for r in lines[1:]]
    # the magnetometer's file lost its first two lines: its row i is the accelerometer's row i + 2
    joined = [",".join(a[:3] + b[3:]) for a, b in zip(body[2:], body[:-2])]
    log = tmp_path / "two_files_joined.csv"
    log.write_text("\n".join([head] + joined) + "\n")
    desc = sensor.load(str(REAL / CK[1]))
    rep = checks.run(importlog.import_log(str(log), desc)[0])
    assert rep.lag_rows == 2, rep.lines()
    desc.mag.lag = rep.lag_rows
    fixed = importlog.import_log(str(log), desc)[0]
    assert len(fixed) == len(joined) - 2
    assert checks.run(fixed).lag_rows == 0


def _tumble(skew_rows=0.0, n=4000, hz=50.0, seed=5):
    """The typical probe turned smoothly through all orientations (no linear
    acceleration), the fluxgate sampled skew_rows of a row after the
    accelerometer."""
    rng = np.random.default_rng(seed)
    tk = np.arange(0.0, n / hz + 2.0, 0.5)
    inc = 5.0 + 170.0 * (0.5 + 0.5 * np.sin(np.cumsum(rng.normal(0.0, 0.5, len(tk)))))
    azi, tf = np.cumsum(rng.normal(0.0, 40.0, len(tk))), np.cumsum(rng.normal(0.0, 60.0, len(tk)))
    s = load_scenario("typical")
    s.mag_skew = fx.SamplingSkew(skew_rows / hz)
    ds = generate_raw(s, trajectory=Trajectory(tk, inc, azi, tf), t_s=np.arange(n) / hz + 0.5, seed=seed)
    for c in ("inc_deg", "azi_deg", "tf_deg"):
        ds.columns.pop(c, None)
    return ds


@pytest.fixture(scope="module")
def tumble():
    return _tumble()


def test_an_emulated_tumble_in_step_names_nothing(tumble):
    rep = checks.run(tumble)
    assert rep.lag_rows == 0 and not _lag_findings(rep, ("error", "warning", "note")), rep.lines()
    assert abs(rep.lag_curve["lag_rows"]) < 0.1


@pytest.mark.parametrize("k", [1, -1, 2])
def test_an_emulated_tumble_shifted_is_named_and_the_curve_finds_the_shift(tumble, k):
    rep = checks.run(_shifted(tumble, k))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message
    assert abs(rep.lag_curve["lag_rows"] - k) < 0.1


@pytest.mark.parametrize("skew", [0.3, -0.3])
def test_a_sampling_skew_within_a_row_is_a_note_not_a_shift(skew):
    """The fluxgate sampled 0.3 row after (or before) the accelerometer: the
    curve's minimum is at -skew, no whole-row lag fixes it, nothing named."""
    rep = checks.run(_tumble(skew))
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()
    (note,) = _lag_findings(rep, ("note",))
    assert abs(note.figures["curve_lag_rows"] + skew) < 0.05 and "within a row" in note.message


def test_a_skew_beyond_half_a_row_names_the_nearest_row_and_the_skew_left():
    rep = checks.run(_tumble(0.7))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == -1 and ("a whole-row lag leaves +0.2" in f.message
                                   or "a whole-row lag leaves +0.3" in f.message), f.message
    assert abs(f.figures["curve_lag_rows"] + 0.7) < 0.05


def _stretch(ds, a, b):
    return dataset.RawDataset({k: v[a:b] for k, v in ds.columns.items()}, dict(ds.meta))


@pytest.mark.parametrize("rows", [(0, 4000), (4000, 8000), (8000, 12000)])
def test_a_held_out_stretch_of_the_ck_log_in_step_names_no_shift(ck, rows):
    rep = checks.run(_stretch(ck[0], *rows))
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


@pytest.mark.parametrize("rows,k", [((8000, 12000), 2), ((4500, 10500), 2)])
def test_a_held_out_stretch_shifted_never_gets_another_lag(ck, rows, k):
    """On these stretches the dip's raw spread (calibration errors left in)
    is least one row beyond the shift made (its least value on the clean
    stretch sits at +1 to +2 rows); the calibrated lag curve rounds to the
    shift, so no other lag is named."""
    rep = checks.run(_shifted(_stretch(ck[0], *rows), k))
    assert rep.lag_rows in (0, k), rep.lines()
    assert round(rep.lag_curve["lag_rows"]) in (k - 1, k), rep.lag_curve
    for f in _lag_findings(rep):
        assert f"lag = {k}" in f.message, f.message
