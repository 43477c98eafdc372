"""procedures.demo.acting_effects: the demo's line outside its band names
only the effects outside the prediction that act in its run."""
from types import SimpleNamespace

import numpy as np

from inclino.formats.calfile import Calibration
from inclino.procedures.demo import acting_effects


def _acceptance(temp_c):
    pts = [{"after": {"azi_rms_deg": 0.0}, "pose": [inc, azi, 0.0], "temp_c": temp_c}
           for inc in (2.0, 30.0, 60.0, 90.0) for azi in (0.0, 90.0, 180.0, 270.0)]
    return SimpleNamespace(points=pts)


def test_temperature_coefficients_are_not_named_at_one_constant_temperature():
    """The typical probe has temperature coefficients; a run and an
    acceptance at one constant 25 degC (the mean of equal values differs
    from each by ~1e-15 degC) give them nothing to act through, so they are
    not listed; 10 degC apart they are, with the azimuth RMS they put on the
    acceptance."""
    run = SimpleNamespace(columns={"temp_c": np.full(94, 25.0) + np.r_[0.0, np.full(93, 1e-15)]})
    cal = Calibration()
    names = [n for n, _ in acting_effects("typical", run, _acceptance(25.0), cal)]
    assert not [n for n in names if n.startswith("temperature")], names
    warm = acting_effects("typical", run, _acceptance(35.0), cal)
    t = [(n, v) for n, v in warm if n.startswith("temperature")]
    assert t and "over 10 degC" in t[0][0] and np.isfinite(t[0][1]) and t[0][1] > 0
