"""A temperature term against a cubic nonlinearity of its own axis, on a
pose-free log whose orientations and temperature share a slow course.

The data come from a simulator written here on its own (numpy and
tests/indep.py's body(), from docs/conventions.md): a sensor with offsets,
scales, cross-axis terms and a misalignment, turned smoothly through the
sphere for 2000 rows at 10 Hz (the inclination's swing widening and
narrowing over the run), white noise, the temperature on a slow ramp.  An
acc z term c z^3 (no library effect) leaves on |g| a slow course in time
that the ramp follows: a temperature term of acc z was named for it on 4
of 12 seeds (100-111) at c = 2e-3 g (p 1.5e-4 to 4e-9).  A temperature
term is a function of the temperature alone, a nonlinearity of the axis'
reading alone: fitted beside the cubic, the temperature term is not
significant there (p 0.63 to 0.95) while the cubic beside it is (p 1e-33
to 1e-20), and it is reported as confounded with that cubic, not named.
A real acc z temperature bias of 50 ug/degC on the same logs stays named
(11 of 12 seeds, as before; seed 100 names nothing either way), and a
temperature scale of 200 ppm/degC 12 of 12.
"""
from indep import smooth_log
from inclino.diagnose.analysis import diagnose
from inclino.formats.dataset import read_raw


def _diagnose(tmp_path, text):
    p = tmp_path / "smooth.csv"
    p.write_text(text)
    return diagnose(read_raw(str(p)))


def test_a_cubic_the_temperature_ramp_follows_is_not_named_as_a_temperature_term(tmp_path):
    """Seed 103: a temperature bias of acc z (-3.6e-5 g/degC, p 1.8e-5) was
    named for the cubic; beside the cubic its p is 0.86."""
    r = _diagnose(tmp_path, smooth_log(103, cubic=2e-3))
    assert not any(e.name.startswith("temperature") for e in r.effects), r.names()
    cf = [c for c in r.confounded if c["with"] == "a cubic nonlinearity of acc z"]
    assert [c["effect"] for c in cf] == ["temperature-bias:acc:z"], r.confounded
    assert not cf[0]["named"]
    bc = cf[0]["beside_cubic"]
    assert bc["p_beside"] > 0.01 and bc["p_cubic_beside"] < 1e-6 and bc["cubic_takes_it"], bc
    text = r.summary()
    assert "not named: temperature-bias (acc z): confounded with a cubic nonlinearity of acc z" in text, text
    assert "which takes its place" in text, text


def test_a_temperature_scale_taken_from_the_cubic_is_refused_too(tmp_path):
    """Seed 108: a temperature scale of acc z (129 ppm/degC) was named for
    the cubic."""
    r = _diagnose(tmp_path, smooth_log(108, cubic=2e-3))
    assert not any(e.name.startswith("temperature") for e in r.effects), r.names()
    assert any(c["effect"].startswith("temperature-") and c["with"] == "a cubic nonlinearity of acc z"
               for c in r.confounded), r.confounded


def test_a_real_temperature_bias_of_the_axis_is_still_named_beside_the_cubic(tmp_path):
    """The same log with a 50 ug/degC temperature bias of acc z and no
    cubic: named, and significant beside the cubic the check fits."""
    r = _diagnose(tmp_path, smooth_log(103, tbias_g_per_c=50e-6))
    assert ("temperature-bias", "acc", "z") in r.names(), r.names()
    e = next(e for e in r.effects if e.name == "temperature-bias")
    assert abs(e.estimate - 50e-6) < 4 * e.stderr, (e.estimate, e.stderr)
    assert e.detail["beside_cubic"]["p_beside"] < 1e-6, e.detail
    assert not any(c["with"] == "a cubic nonlinearity of acc z" for c in r.confounded), r.confounded
