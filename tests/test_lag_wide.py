"""The triads' row pairing beyond MAX_LAG rows (inclino.checks._wide_lag):
two files joined with more than a line lost, or started apart.  The
routes that find a shift within 3 rows named the edge of their range (a
wrong lag) or nothing on real logs shifted by 4 to 20 rows: the SAP6 shots
(one row a position) shifted by 4 rows were passed in silence with their
dip spread over 19 deg, the CK hand tumble shifted by 8 got a note, the
micropython-fusion log shifted by 5 and 10 rows was named +3 and nothing.
Each shift below fails with the search held to 3 rows.  Also: a hand
tumble simulated here, in step, gets no note of a possible shift where
its lag curve puts it in step."""
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.formats import dataset, importlog, sensor
from rows import band_noise as _band
from rows import shifted as _shifted

REAL = Path(__file__).parent / "data" / "real"


def _load(log, toml):
    return importlog.import_log(str(REAL / log), sensor.load(str(REAL / toml)))[0]


def _rows(ds, a, b):
    return dataset.RawDataset({key: v[a:b] for key, v in ds.columns.items()}, dict(ds.meta))


def _named(rep):
    return [f for f in rep.findings if f.check == "row-alignment" and f.level in ("error", "warning")]


@pytest.fixture(scope="module")
def ck():
    return _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")


@pytest.mark.parametrize("k", [4, -4])
def test_shots_shifted_beyond_three_rows_are_named_with_their_lag(k):
    """SAP6's 24 shots, one row each: a shift of 4 mispairs every row (the
    dip spreads ~19 deg as paired, ~1 deg at the shift); it was silent."""
    rep = checks.run(_shifted(_load("sap6/BB.csv", "sap6/sensor.toml"), k))
    (f,) = _named(rep)
    assert rep.lag_rows == k and f.level == "error" and f"lag = {k}" in f.message, rep.lines()
    assert f.figures["wide_row_fixed"] and f.figures["wide_route"] == "spread"


@pytest.mark.parametrize("k", [8, -8, 20])
def test_a_hand_tumble_shifted_by_many_rows_is_named_with_its_lag(ck, k):
    """The CK log's dip spreads least a row off its pairing; the lag curve
    of the rows paired there moves it back to the shift made."""
    rep = checks.run(_shifted(ck, k))
    (f,) = _named(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message, rep.lines()
    assert round(rep.lag_curve["lag_rows"]) == k, rep.lag_curve


@pytest.mark.parametrize("k", [5, -5, 10])
def test_the_fusion_log_shifted_by_five_or_ten_rows_is_not_named_three(k):
    rep = checks.run(_shifted(_load("micropython_fusion/mpudata.csv", "micropython_fusion/sensor.toml"), k))
    assert rep.lag_rows == k and any(f"lag = {k}" in f.message for f in _named(rep)), rep.lines()


def test_a_turn_that_repeats_does_not_name_a_lag_a_period_away(ck):
    """CK rows 6000-12000 a row behind: the dip's mean deviation is least 39
    rows the other way (the hand's turn repeats), where the dip spreads 7x
    its least; the spread has the last word, and no lag beyond 3 rows is
    named (it named -39 before that rule)."""
    rep = checks.run(_shifted(_rows(ck, 6000, 12000), 1))
    assert rep.lag_rows in (0, 1), rep.lines()
    assert not any(abs(f.figures.get("lag_rows_about", 0)) > checks.MAX_LAG for f in rep.findings)


def test_a_shift_whose_row_the_search_does_not_fix_is_a_warning_of_about_that_many(ck):
    """CK rows 0-6000, turned mostly about the vertical (no lag curve):
    shifted by 10 rows, the dip spreads least at +11; the row is not fixed,
    so no lag is named, but the warning says the triads are out of step by
    about that many rows."""
    rep = checks.run(_shifted(_rows(ck, 0, 6000), 10))
    (f,) = _named(rep)
    assert rep.lag_rows == 0 and f.level == "warning" and "by about" in f.message, rep.lines()
    assert f"about {f.figures['lag_rows_about']:+d} rows (the row not fixed:" in f.message
    assert abs(f.figures["lag_rows_about"] - 10) <= 2


def test_a_lag_curve_beyond_the_rows_tried_is_a_note_not_silence(ck):
    """CK rows 3000-9000 three rows ahead: the lag curve, at -3.77 +- 0.51,
    rounds to -4, beyond the shifts the spread tried; nothing was said."""
    rep = checks.run(_shifted(_rows(ck, 3000, 9000), -3))
    notes = [f for f in rep.findings if f.check == "row-alignment"]
    assert notes and any("beyond the 3 rows" in f.message for f in notes), rep.lines()


def _held(ds, rows=30, seed=7):
    """Each row held for `rows` noisy rows (1 mg, 100 nT): a step-and-hold log."""
    rng = np.random.default_rng(seed)
    c = {key: np.repeat(v, rows) for key, v in ds.columns.items()}
    for key in dataset.ACC_COLS:
        c[key] = c[key] + rng.normal(0.0, 1e-3, len(c[key]))
    for key in dataset.MAG_COLS:
        c[key] = c[key] + rng.normal(0.0, 100.0, len(c[key]))
    return dataset.RawDataset(c, dict(ds.meta))


@pytest.mark.parametrize("name,k", [("BB", 4), ("BB", -4), ("HC", 8), ("CF", 20)])
def test_shots_held_for_many_rows_shifted_far_are_named_to_the_row(name, k):
    """SAP6's shots held 30 rows each: a shift mispairs only the rows where
    the shot changes, so the dip's spread is least over a few rows around
    the shift (not to the row); the changes of position, mispaired by a row
    either way, fix it."""
    rep = checks.run(_shifted(_held(_load(f"sap6/{name}.csv", "sap6/sensor.toml")), k), declared_static=True)
    (f,) = _named(rep)
    assert rep.lag_rows == k and f"lag = {k}" in f.message, rep.lines()


def test_a_lag_curve_a_row_beyond_the_rows_tried_is_named_when_the_rows_paired_there_are_in_step(ck):
    """The whole CK log four rows ahead: the dip's spread is least at -3
    (its skew), the lag curve at -4.39 +- 0.16 from the trials at the edge;
    the curve of the rows paired at -4 puts them in step (-0.07 +- 0.11):
    named -4 (it was a note)."""
    rep = checks.run(_shifted(ck, -4))
    assert rep.lag_rows == -4 and any("lag = -4" in f.message for f in _named(rep)), rep.lines()


def _tumble(seed, n=6000, rate=100.0):
    """A hand tumble in step, simulated here: the body turned at 60 deg/s
    RMS per axis (0.2-1 Hz), 10 mg of the hand's acceleration (0.5-5 Hz) on
    the accelerometer, 1 mg and 100 nT of white noise, dip 60 deg."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    turn = Rotation.from_rotvec(np.radians(_band(rng, n, 0.2, 1.0, rate, 60.0)) / rate)
    C = [Rotation.random(random_state=seed)]
    for i in range(1, n):
        C.append(turn[i - 1].inv() * C[-1])
    Cm = np.array([c.as_matrix() for c in C])  # world -> body
    dip = np.radians(60.0)
    acc = Cm @ np.array([0.0, 0.0, 1.0]) + _band(rng, n, 0.5, 5.0, rate, 0.01) + rng.normal(0, 1e-3, (n, 3))
    mag = Cm @ (50_000.0 * np.array([np.cos(dip), 0.0, np.sin(dip)])) + rng.normal(0, 100.0, (n, 3))
    cols = {"t_s": np.arange(n) / rate, **{c: acc[:, j] for j, c in enumerate(dataset.ACC_COLS)},
            **{c: mag[:, j] for j, c in enumerate(dataset.MAG_COLS)}}
    return dataset.RawDataset(cols, {"field_nT": "50000", "dip_deg": "60"})


@pytest.mark.parametrize("seed", [0, 2, 4])
def test_a_tumble_in_step_whose_lag_curve_says_so_gets_no_note_of_a_possible_shift(seed):
    """The count of rows brought back by a shift (a route for a few
    positions held) finds 12-25 rows "in line with" a shift of a row or
    three on every such tumble; the lag curve puts it in step within 0.09
    row.  The note "may be paired out of step ... not named" that said so on
    every clean tumble is not given where the curve puts the rows in step."""
    rep = checks.run(_tumble(seed))
    assert rep.lag_rows == 0 and abs(rep.lag_curve["lag_rows"]) < 0.5
    assert not [f for f in rep.findings if f.check == "row-alignment"], rep.lines()


@pytest.mark.parametrize("k", [1, -1, 7, -12])
def test_a_simulated_tumble_shifted_is_named_with_its_lag(k):
    rep = checks.run(_shifted(_tumble(1), k))
    assert rep.lag_rows == k and any(f"lag = {k}" in f.message for f in _named(rep)), rep.lines()


def test_a_dozen_shots_all_mispaired_name_no_lag_by_chance():
    """SAP6's BB with 12 of its 24 shots lost at the start of one file:
    every row left is mispaired, and the least of the seven spreads of 6-12
    rows each (at -3) was named; no half can tell, and it is not 3x below
    the other shifts': a note, no lag."""
    rep = checks.run(_shifted(_load("sap6/BB.csv", "sap6/sensor.toml"), 12))
    assert rep.lag_rows == 0 and not _named(rep), rep.lines()
    assert any(f.check == "row-alignment" and "too few rows" in f.message for f in rep.findings)


def test_a_dip_that_scatters_off_the_header_says_the_rows_may_be_out_of_step():
    """A tumble simulated here with its magnetometer 150 rows behind, beyond
    the 50 rows searched: the dip reads 20 deg off the header's and
    scatters by ~30 deg from row to row; the warning names a pairing out
    of step beside a wrong dip_deg or a disturbed field."""
    rep = checks.run(_shifted(_tumble(1), 150))
    (f,) = [f for f in rep.findings if f.check == "dip-sign" and f.level == "warning"]
    assert "paired out of step" in f.message and f.figures["dip_spread_deg"] > checks.DIP_MISMATCH_DEG


def test_a_shift_beyond_the_rows_searched_is_said_to_be_at_least_the_edge():
    """The same tumble 80 rows behind: the dip spreads least at +50, the
    edge of the search; the warning says 50 rows or more, not about 50."""
    rep = checks.run(_shifted(_tumble(1), 80))
    (f,) = _named(rep)
    assert rep.lag_rows == 0 and "+50 rows or more" in f.message, rep.lines()


@pytest.mark.parametrize("spreads,near", [({"1": 3.75, "2": 3.48, "3": 3.57}, [3]),
                                          ({"1": 4.9, "2": 3.48, "3": 4.6}, [])])
def test_a_shift_whose_neighbour_spreads_as_little_is_said_not_fixed(spreads, near):
    """A log of 1 252 rows with its magnetometer 3 rows behind spread the
    dip 3.48 deg at +2 and 3.57 at +3: "lag = 2" was named as the lag, and
    after it nothing was named.  A neighbour within LAG_NEIGHBOUR of the
    least is said to fit nearly as well; a sharp least is not."""
    ds = dataset.RawDataset({c: np.zeros(10) for c in dataset.ACC_COLS + dataset.MAG_COLS}, {})
    rep = checks.CheckReport(rows=10, triads="both")
    checks._name_shift(ds, rep, "spread", 2, "the dip spreads", 4.13, 3.48, {"dip_spread_by_lag_deg": spreads})
    (f,) = rep.findings
    assert f.figures["lags_as_near"] == near
    assert ("lag = 3 fits nearly as well" in f.message) == bool(near), f.message


def test_a_shift_the_lag_curve_names_has_no_note_beside_it_that_another_was_not_named():
    """The CK log's second half, its magnetometer three rows ahead: the
    dip's spread reads -2, which the curve (at -3) overrules; the note that
    said "-2 ... not named" beside the warning naming -3 is not given."""
    ck = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")
    rep = checks.run(_shifted(_rows(ck, 6000, 12000), -3))
    assert rep.lag_rows == -3 and _named(rep), rep.lines()
    assert not [f for f in rep.findings if f.check == "row-alignment" and "not named" in f.message], rep.lines()
