"""Pose-free structure tests on a smoothly moving log whose noise is
serially correlated, as a sensor's own low-pass filter makes it.

The data come from a simulator written here on its own (numpy and
tests/indep.py's body(), from docs/conventions.md): a sensor with offsets,
scales, cross-axis terms and a misalignment, turned smoothly through the
sphere (inclination swinging, azimuth and toolface turning) for 2000 rows
at 10 Hz, with a temperature ramp, and AR(1) noise on every axis (each
row's noise rho times the row before's plus an innovation).  Nothing in
the data beyond that constant calibration: the final residual's Ljung-Box
test and the direction families' F-tests read such a log as structure no
effect explains (8 of 8 seeds at each of rho 0.8, 0.9, 0.95, a ramp and a
cycled temperature alike, and 16 of 16 under a slowly wandering
temperature; white noise 0 of 16), until each family's F-test is deflated
by its Bartlett factor against the residual and the whiteness test allows
the residual an AR(p) noise model (0 of 56 at rho 0.8-0.95, 0 of 16
white, none naming an effect).
"""
import pytest

from indep import smooth_log
from inclino.diagnose.analysis import diagnose
from inclino.formats.dataset import read_raw


def _diagnose(tmp_path, text):
    p = tmp_path / "smooth.csv"
    p.write_text(text)
    return diagnose(read_raw(str(p)))


@pytest.mark.parametrize("seed, rho", [(0, 0.8), (1, 0.9), (2, 0.95)])
def test_a_clean_smooth_log_with_correlated_noise_is_explained(tmp_path, seed, rho):
    r = _diagnose(tmp_path, smooth_log(seed, rho))
    assert not r.effects, r.names()
    assert not r.unexplained, r.structure["significant"]
    # the channels were read as serially correlated, and their tests deflated (not merely passed)
    by = r.structure["serial"]["by_channel"]
    assert all(c["correlated"] for c in by.values()), by
    assert all(f > 2.0 for c in by.values() for f in c["factors"].values()), by


def test_the_same_log_with_white_noise_is_tested_as_before(tmp_path):
    r = _diagnose(tmp_path, smooth_log(0, 0.0))
    assert not r.effects and not r.unexplained, (r.names(), r.structure["significant"])
    assert not any(c["correlated"] for c in r.structure["serial"]["by_channel"].values())


def test_an_unmodelled_nonlinearity_under_correlated_noise_is_still_unexplained(tmp_path):
    """A 0.016 g z^3 term on acc z (no library effect): at rho 0.9 the dip
    against the magnetometer's direction finds it on 4 of 6 seeds (100-105),
    at p 0 to 6e-4; this seed at p < 1e-6.  (A quarter of it on white noise
    is found on 6 of 6.)"""
    r = _diagnose(tmp_path, smooth_log(101, 0.9, cubic=1.6e-2))
    assert r.unexplained, r.structure


def test_a_field_drift_under_correlated_noise_is_still_named(tmp_path):
    """A 0.2 nT/s drift of |b| at rho 0.9: named on 6 of 6 seeds (100-105;
    as often as before the structure tests accounted for the correlation),
    and the final residual explained."""
    r = _diagnose(tmp_path, smooth_log(100, 0.9, drift_nT_s=0.2))
    assert r.names() == [("field-drift", "field", "total")], r.names()
    assert not r.unexplained, r.structure["significant"]


def test_a_failed_whiteness_test_on_correlated_rows_says_what_it_tested():
    """On a channel read as serially correlated the whiteness test is of
    what an AR(p) noise model leaves: a failed one says so (and its order),
    not that the rows are merely correlated, which they are allowed to be."""
    from inclino.diagnose.result import _structure_text

    x = {"channel": "|b|", "test": "whiteness", "p": 2e-9, "ar_order": 2}
    assert _structure_text(x) == ("|b| residual more than serially correlated noise (what an AR(2) noise model "
                                  "leaves is not white; Ljung-Box p = 2e-09)")
