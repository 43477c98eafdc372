"""The triads' row pairing on continuously moving logs: the dip invariant's
lag curve (inclino.checks._lag_curve).  On the hand-tumbled CK log
(neighbouring rows about 1 deg apart, a one-row shift changes the dip's
spread by 2 %), on an emulated tumble without the real log's dynamic
acceleration, and on a simulated sensor turned about a grip point (the
hand's lever-arm acceleration the curve fits out): the lag named is the
shift made, the unshifted log is not named, a skew within a row is a note,
never a named shift."""
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.formats import dataset, importlog, sensor
from inclino.model import effects as fx
from inclino.model.scenario import generate_raw, load_scenario
from inclino.model.world import Trajectory
from inclino.benchmarks.realdata import held_positions, smooth_tumble
from rows import shifted as _shifted

REAL = Path(__file__).parent / "data" / "real"
CK = ("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")


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
    """The curve follows the shift to a fraction of a row.  With the hand's
    lever-arm acceleration fitted out the clean log sits a fraction of a row
    off 0, so one direction clears half a row by 3 standard errors and is
    named (next test), the other is within them: a note naming the possible
    lag.  Never a wrong lag."""
    rep = checks.run(_shifted(ck[0], k))
    assert abs(rep.lag_curve["lag_rows"] - ck[1].lag_curve["lag_rows"] - k) < 0.2, rep.lag_curve
    assert rep.lag_rows in (0, k)
    if rep.lag_rows == 0:
        (note,) = _lag_findings(rep, ("note",))
        assert note.figures["lag_rows_possible"] == k and "not named" in note.message


def test_a_one_row_shift_of_the_ck_log_is_named_where_the_curve_clears_half_a_row(ck):
    """The clean log's curve sits at a fraction f of a row: a shift of k rows
    puts it at k + f, and the shift whose k + f lies 3 standard errors beyond
    half a row is named, as a warning with that lag, each half agreeing."""
    c = ck[1].lag_curve
    k = 1 if c["lag_rows"] > 0 else -1  # the side the clean log leans to: k + f is the farther from half a row
    rep = checks.run(_shifted(ck[0], k))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == k and f.level == "warning" and f"lag = {k}" in f.message, rep.lines()
    assert all(round(h) == k for h in rep.lag_curve["halves_rows"]), rep.lag_curve
    assert abs(rep.lag_curve["lag_rows"]) - 0.5 > checks.LAG_CURVE_SE * rep.lag_curve["se_rows"], rep.lag_curve


def _check_dirs(ds):
    """The unit directions the row-alignment check pairs (both triads after
    their ellipsoid fits; the CK log's axes are as declared)."""
    block = slice(0, checks.LAG_ROWS)
    ug = checks._unit_dirs(ds.acc[block], float(ds.meta.get("gravity_g") or 1.0))[0]
    ub = checks._unit_dirs(ds.mag[block], float(ds.meta.get("field_nT") or 50_000.0))[0]
    return ug, ub


def test_the_lever_arm_terms_narrow_the_ck_log_lag_curve(ck):
    """The hand's acceleration is what scatters the CK log's curve: fitted
    out at each trial shift, the jackknife standard error is smaller than
    with the triads' calibration alone."""
    ds, rep = ck
    ug, ub = _check_dirs(ds)
    with_arm, without = checks._lag_curve(ug, ub), checks._lag_curve(ug, ub, lever_arm=False)
    # the directions are the check's own: the curve is the one it reported
    assert with_arm["lag"] == pytest.approx(rep.lag_curve["lag_rows"], abs=1e-9)
    assert with_arm["se"] < without["se"], (with_arm, without)


def _hand_turned(n=3000, r=(1.0, -0.7, 1.5), seed=3):
    """A sensor turned by a hand about a grip point: a smooth random body
    rate w (rad/row, ~1 deg/row), the orientation integrated from it
    exactly, gravity and a 60 deg dip field as the body frame sees them, and
    the accelerometer reading gravity plus alpha x r + w x (w x r)."""
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    knots = np.linspace(0.0, n, n // 50 + 1)
    rate = CubicSpline(knots, rng.normal(0.0, 0.02, (len(knots), 3)))
    t = np.arange(n, dtype=float)
    w, alpha = rate(t), rate(t, 1)
    steps = Rotation.from_rotvec(0.5 * (w[:-1] + w[1:]))
    R = [Rotation.identity()]
    for s in steps:
        R.append(R[-1] * s)
    R = Rotation.concatenate(R).inv()
    dip = np.radians(60.0)
    g, b = R.apply([0.0, 0.0, 1.0]), R.apply([np.cos(dip), 0.0, np.sin(dip)])
    a_lin = np.cross(alpha, r) + np.cross(w, np.cross(w, r))
    acc = g + a_lin
    return acc / np.linalg.norm(acc, axis=1, keepdims=True), b, a_lin


def test_the_lever_arm_columns_take_out_a_hand_s_acceleration(monkeypatch):
    """Rigid-body kinematics, not the columns' own formula: the accelerometer
    of a sensor turned about a grip point 10-30 mg off gravity (CK's median
    row: 22 mg).  The six columns (their r fitted) leave a small part of the
    invariant's misfit the calibration terms alone leave, and the curve with
    them, fitted in one piece, sits closer to the true pairing (0) than
    without; fitted in parts (as the check does) it stays there."""
    for scale in (3.0, 10.0):
        monkeypatch.setattr(checks, "LAG_CURVE_PARTS", 1)
        ug, ub, a_lin = _hand_turned(r=tuple(scale * np.array([1.0, -0.7, 1.5])))
        assert 0.005 < np.sqrt(np.mean(np.sum(a_lin ** 2, 1))) < 0.03  # g: the acceleration meant
        i = np.arange(checks.MAX_LAG + 1, len(ug) - checks.MAX_LAG - 1)
        (cols,) = checks._lever_arm_columns(ug, ub, i, [0])
        before = np.sqrt(np.mean(checks._invariant_misfit(ug[i], ub[i]) ** 2))
        after = np.sqrt(np.mean(checks._invariant_misfit(ug[i], ub[i], cols) ** 2))
        assert after < 0.25 * before, (scale, np.sqrt(np.mean(np.sum(a_lin ** 2, 1))), before, after)
        c0, c1 = checks._lag_curve(ug, ub, lever_arm=False), checks._lag_curve(ug, ub)
        assert abs(c1["lag"]) < abs(c0["lag"]) and abs(c1["lag"]) < 3 * c1["se"], (scale, c0, c1)
        monkeypatch.undo()
        c2 = checks._lag_curve(ug, ub)
        assert abs(c2["lag"]) < 3 * c2["se"], (scale, c2)


def test_the_lever_arm_terms_leave_a_tumble_without_linear_acceleration_alone(tumble):
    """No hand's acceleration: r fits to ~0 and the curve is where it was."""
    ug, ub = _check_dirs(tumble)
    c0, c1 = checks._lag_curve(ug, ub, lever_arm=False), checks._lag_curve(ug, ub)
    assert abs(c1["lag"] - c0["lag"]) < 0.01 and abs(c1["se"] - c0["se"]) < 0.01, (c0, c1)


def test_the_smoothing_is_scipy_s_savitzky_golay_filter():
    from scipy.signal import savgol_filter

    v = np.random.default_rng(0).normal(size=(200, 3)).cumsum(0)
    n = checks.LAG_LEVER_ROWS
    assert np.allclose(checks._savgol_rows(v, n), savgol_filter(v, n, 3, axis=0), rtol=0, atol=1e-10)


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


def test_a_shift_whose_raw_spread_halves_disagree_is_named_from_the_curve(ck):
    """CK rows 6000-12000 (clean curve -0.36 +- 0.16) with the magnetometer
    three rows behind: the dip's raw spread finds +3 on the whole stretch but
    not on each half on its own (each half's spread is skewed by the
    calibration errors it leaves in), which had left the shift unnamed.
    The lag curve, its calibration fitted out, is at +2.64 with both
    halves beyond half a row that way: named +3 from the curve (the raw
    spread searched wider puts its least at +4, a row out: the curve of
    the rows paired there moves it back by the row)."""
    rep = checks.run(_shifted(_stretch(ck[0], 6000, 12000), 3))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == 3 and "lag = 3" in f.message, rep.lines()
    assert f.figures["route"] == "curve" or (f.figures.get("wide_lag_rows") != 3 and "a further" in f.message)


def test_a_curve_whose_halves_straddle_zero_names_no_nearest_row(ck):
    """The same stretch a row behind: the curve at +0.64 but its first half at
    -0.38: the halves do not agree on the side, nothing is named."""
    rep = checks.run(_shifted(_stretch(ck[0], 6000, 12000), 1))
    halves = rep.lag_curve["halves_rows"]
    assert rep.lag_curve["lag_rows"] > 0.5 and min(halves) < 0 < max(halves), rep.lag_curve
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


@pytest.mark.parametrize("k", [1, -1])
def test_a_one_row_shift_of_the_whole_ck_log_is_named_either_way(ck, k):
    """Each half of the log fitted with its own calibration and lever arms,
    their misfits summed: the hand's grip and the part's state may change
    along 12 000 rows, and one fit for the whole log left the clean log
    leaning by a fifth of a row, so that a shift one way sat within its
    standard error of half a row.  Either one-row shift is now named, with
    its lag, and each half of the log rounds to it on its own."""
    rep = checks.run(_shifted(ck[0], k))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message
    assert all(round(h) == k for h in rep.lag_curve["halves_rows"]), rep.lag_curve


def test_a_log_held_at_one_orientation_has_no_lag_curve(rng):
    """Both triads read one orientation with their noise (a static log):
    every shift pairs rows alike, so there is no pairing to find, and the
    lever-arm terms would fit the curve to the noise (a real static log,
    4 orientations' worth of noise in 18 000 rows, came out at
    +2.2 +- 0.13 rows and was named).  No curve, nothing named."""
    from inclino.formats.dataset import RawDataset

    n = 6000
    g = np.array([0.1, -0.2, 0.97])
    b = 48_000.0 * np.array([0.35, 0.1, 0.93])
    acc = g + rng.normal(0.0, 8e-4, (n, 3))
    mag = b + rng.normal(0.0, 80.0, (n, 3))
    ds = RawDataset({"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
                     "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}, {"field_nT": 48_000.0})
    for k in (0, 1, 2):
        rep = checks.run(_shifted(ds, k) if k else ds)
        assert rep.lag_curve is None and rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


FUSION = ("micropython_fusion/mpudata.csv", "micropython_fusion/sensor.toml")


def test_a_log_with_a_skew_of_its_own_shifted_a_row_is_named_either_way():
    """micropython-fusion's MPU9150 log (2 041 rows at ~34 rows/s, turned
    by hand): as logged its curve sits at +0.38 row (the magnetometer read
    ~12 ms before the accelerometer), and nothing is named.  With the
    magnetometer a row behind it is at +1.38, each half at +1.35 and
    +1.68: both beyond half a row the same way, so the shift of +1 is
    named (the halves rounding to 1 and 2 had left it unnamed), and two
    rows the other way (-1.61) are named -2.  A row ahead (-0.61 +- 0.29,
    halves -0.66 and -0.25) is within 3 standard errors of half a row: its
    nearest whole row, -1, is named as a warning that says a skew of the
    log's own is not ruled out (it was not named at all before)."""
    ds = importlog.import_log(str(REAL / FUSION[0]), sensor.load(str(REAL / FUSION[1])))[0]
    rep = checks.run(ds)
    assert not _lag_findings(rep) and 0.2 < rep.lag_curve["lag_rows"] < 0.6
    for k, want, beyond in ((1, 1, True), (-2, -2, True), (-1, -1, False)):
        rep = checks.run(_shifted(ds, k))
        found = _lag_findings(rep)
        assert found and found[0].figures["lag_rows"] == want, (k, rep.lag_curve)
        halves = rep.lag_curve["halves_rows"]
        assert all(np.sign(h) == np.sign(want) for h in halves)
        assert all(abs(h) > 0.5 for h in halves) == beyond
        if not beyond:
            assert found[0].level == "warning" and found[0].figures["route"] == "nearest"
            assert "not ruled out" in found[0].message and "look paired out of step" in found[0].message


BROAD = ("broad/02.csv", "broad/with_acc.toml")


@pytest.fixture(scope="module")
def broad_first_1250():
    """BROAD's trial 02 (a real IMU turned by hand and by a rig, 2 577 rows at
    ~286 rows/s): its first 1 250 rows, fewer than the LAG_CURVE_ROWS the
    lag curve's full rules need."""
    ds = importlog.import_log(str(REAL / BROAD[0]), sensor.load(str(REAL / BROAD[1])))[0]
    return _stretch(ds, 0, 1250)


def test_a_short_stretch_in_step_names_nothing(broad_first_1250):
    rep = checks.run(broad_first_1250)
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


@pytest.mark.parametrize("k", [1, -1])
def test_a_one_row_shift_of_a_short_real_log_is_named_from_its_curve(broad_first_1250, k):
    """On 1 250 rows the dip's spread changes too little from a row to the
    next to name a shift (it was not named either way), and the lag curve
    had needed 2 000 rows.  From 1 000 rows a curve names its row when its
    strict rule holds, each half of the log rounds to that row, its standard
    error is below half a row and its fraction within 0.4 of the row."""
    rep = checks.run(_shifted(broad_first_1250, k))
    (f,) = _lag_findings(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message and f.figures["route"] == "curve", rep.lines()
    c = rep.lag_curve
    assert all(round(h) == k for h in c["halves_rows"]) and abs(c["lag_rows"] - k) < checks.LAG_CURVE_SHORT_LEFT, c


def test_a_short_curve_that_is_not_sure_of_its_row_names_nothing(ck):
    """CK rows 6000-7600, in step: the curve reads +3.37 +- 0.8 with each
    half rounding to +3 (the strict rule alone would name +3); its standard
    error over half a row and its fraction 0.37 from the row keep it from
    naming on fewer than LAG_CURVE_ROWS rows."""
    sub = _stretch(ck[0], 6000, 7600)
    inv = checks._lag_curve(*_check_dirs(sub), min_rows=checks.LAG_CURVE_SHORT_ROWS)
    assert inv is not None and checks._curve_rule(inv["lag"], inv["se"], inv["halves"])[0] == "curve", inv
    assert not checks._short_curve_names(inv["lag"], inv["se"], inv["halves"])
    rep = checks.run(sub)
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


@pytest.mark.parametrize("seed", range(4))
def test_a_one_row_shift_of_a_short_smooth_tumble_is_named_from_its_curve(seed):
    """600 rows turned 2 deg a row: a row changes the dip's spread by a few %
    only (without a curve, the first of these logs was not named either
    way; on others drawn the same way the spread, skewed by the triads'
    calibration errors, named -1 in step and -2 a row behind).  The curve
    from LAG_CURVE_SHORT_ROWS rows, its standard error the larger of a
    jackknife that refits the calibration without each block and one that
    does not, puts each one-row shift at its row."""
    ds = smooth_tumble(600, 2.0, seed)
    rep = checks.run(ds)
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()
    assert abs(rep.lag_curve["lag_rows"]) < 0.25, rep.lag_curve
    for k in (1, -1):
        rep = checks.run(_shifted(ds, k))
        (f,) = _lag_findings(rep)
        assert rep.lag_rows == k and f"lag = {k}" in f.message, rep.lines()
        assert abs(rep.lag_curve["lag_rows"] - k) < 0.25, rep.lag_curve


def test_a_short_stretch_of_a_real_log_whose_curve_refits_loose_names_nothing(ck):
    """CK rows 6000-7500 in step: the curve's first jackknife read +3.33 +-
    0.41 with each half rounding to +3, and +3 was named.  Refitting the
    triads' calibration and the lever arms without each block puts its
    standard error at 1.38 rows (a few blocks carry the fitted terms), and
    nothing is named."""
    rep = checks.run(_stretch(ck[0], 6000, 7500))
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()


@pytest.mark.parametrize("seed", [7, 21, 29])
def test_a_short_curve_keeps_the_other_routes_from_naming_a_wrong_row(seed):
    """Smooth tumbles of 600 rows on which, without a curve, the dip's spread
    (skewed by the triads' calibration errors) named +2 a row behind, and on
    one +1 in step: the curve puts the rows in step, or rules out the row by
    more than LAG_CURVE_SE standard errors beyond half a row (+0.87 +- 0.16
    against +2), and the row named is the shift made."""
    ds = smooth_tumble(600, 2.0, seed)
    assert [checks.run(_shifted(ds, k) if k else ds).lag_rows for k in (0, 1, -1)] == [0, 1, -1]


@pytest.mark.parametrize("seed", [19, 21])
def test_a_few_held_positions_get_no_lag_curve(seed):
    """Six positions held 100 rows each, turned between over 3 rows: the
    turning sits in a few of the curve's blocks, and its curve, resting on
    the 15 rows that turn, read -1.45 +- 0.09 two rows behind (the first
    log) and +2.50 +- 0.002 a row ahead (the second), and overruled the
    count of rows where the position changes.  No curve is fitted there;
    the count names each shift."""
    ds = held_positions(6, 100, 3, seed)
    ug, ub = _check_dirs(ds)
    assert checks._turn_blocks(ug, ub, checks.LAG_CURVE_BLOCKS) < checks.LAG_CURVE_MIN_TURN_BLOCKS
    assert checks._lag_curve(ug, ub, min_rows=checks.LAG_CURVE_SHORT_ROWS, refit=True) is None
    assert [checks.run(_shifted(ds, k) if k else ds).lag_rows for k in (0, 1, -1, 2)] == [0, 1, -1, 2]


@pytest.mark.parametrize("k", [1, -1])
def test_a_short_curve_not_sure_of_its_row_says_what_it_reads(k):
    """BROAD's trial 05, its first 1 000 rows, shifted a row either way: the
    curve reads +0.91 +- 0.48 and -1.09 +- 0.47, each half on the shift's
    side, too loose to name a row on so few rows.  Not named, but said: a
    note with the curve's figures and the rows one standard error allows,
    the shift made among them (before: "not checked to a row" at most)."""
    ds = importlog.import_log(str(REAL / "broad/05.csv"), sensor.load(str(REAL / BROAD[1])))[0]
    rep = checks.run(_shifted(_stretch(ds, 0, 1000), k))
    assert rep.lag_rows == 0 and not _lag_findings(rep), rep.lines()
    (f,) = _lag_findings(rep, ("note",))
    assert "is possible, not named" in f.message and f.figures["lag_rows_possible"] == k, f.message
    lag, se = f.figures["curve_lag_rows"], f.figures["curve_lag_se_rows"]
    assert round(lag - se) <= k <= round(lag + se) and f"{lag:+.2f} +- {se:.2f}" in f.message, f.message
    # in step: nothing named, nothing possible (its note says a row either way would not be named)
    in_step = _lag_findings(checks.run(_stretch(ds, 0, 1000)), ("error", "warning", "note"))
    assert [f.level for f in in_step] == ["note"] and "not checked to a row" in in_step[0].message, in_step
