"""A log whose rows do not show a one-row shift (a stretch of CK's
hand-held log turned mostly about the vertical: the dip invariant sees
only turns about the east-west axis) says that its pairing was checked only
in part, rather than passing in silence; a log that shows a shift either
way says nothing of it."""
from pathlib import Path

import pytest

from test_lag_curve import _shifted, _stretch

from inclino import checks
from inclino.formats import importlog, sensor

REAL = Path(__file__).parent / "data" / "real"


@pytest.fixture(scope="module")
def ck():
    return importlog.import_log(str(REAL / "ck_acc_mag/acc_mag_log.csv"), sensor.load(str(REAL / "ck_acc_mag/sensor.toml")))[0]


def _row_alignment(rep):
    return [f for f in rep.findings if f.check == "row-alignment"]


def test_a_stretch_that_cannot_show_a_shift_says_so(ck):
    s = _stretch(ck, 0, 6000)
    (f,) = _row_alignment(checks.run(s))
    assert f.level == "note" and "would not be named" in f.message and f.figures["unseen_lags_rows"] == [-1, 1]
    # and indeed: shifted a row either way, nothing is named
    for k in (1, -1):
        assert checks.run(_shifted(s, k)).lag_rows == 0


def test_the_way_a_stretch_cannot_show_is_the_way_it_is_not_named(ck):
    """CK rows 6000-12000: a row behind is named (+1 warns), a row ahead
    (curve +0.64, its halves either side of zero) is not; the note names
    that way only."""
    s = _stretch(ck, 6000, 12000)
    (f,) = _row_alignment(checks.run(s))
    unseen = f.figures["unseen_lags_rows"]
    assert len(unseen) == 1
    for k in (1, -1):
        named = checks.run(_shifted(s, k)).lag_rows != 0
        assert named == (k not in unseen), (k, unseen)


def test_a_log_that_shows_a_shift_either_way_says_nothing_of_it(ck):
    assert not _row_alignment(checks.run(ck))


def test_a_short_stretch_says_what_the_lag_curve_needs(ck):
    """Below LAG_CURVE_SHORT_ROWS the curve is not fitted, nor where the
    triads turn about one axis (the note says which); from there to
    LAG_CURVE_ROWS it names a shift only where it is sure of its row.  The
    note says which, in words a reader can act on, and what it says holds:
    the 1 250-row stretch shifted a row either way is not named."""
    (f,) = _row_alignment(checks.run(_stretch(ck, 1800, 1950)))
    assert f.level == "note" and "not determined here (fewer than 200 consecutive rows)" in f.message, f.message
    # 600 rows turned mostly about the vertical: long enough, but its curve has no least to find
    (f,) = _row_alignment(checks.run(_stretch(ck, 1800, 2400)))
    assert f.level == "note" and "not determined here (both triads turned too little, or about one axis only)" \
        in f.message, f.message
    s = _stretch(ck, 6000, 7250)
    (f,) = _row_alignment(checks.run(s))
    assert f.level == "note" and f.figures["unseen_lags_rows"] == [-1, 1], f.message
    assert "lag curve scatters by" in f.message and "on fewer than 2 000 rows the curve names a shift only" in f.message
    for k in (1, -1):
        assert checks.run(_shifted(s, k)).lag_rows == 0
