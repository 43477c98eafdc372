"""A run without the turntable's poses (or with one triad) whose temp_c
changes: calibrate fits no temperature terms (they need the poses and both
triads) and says so, instead of dropping the column without a word."""
from pathlib import Path

import numpy as np
import pytest

from inclino import calib
from inclino.formats import importlog, sensor
from inclino.formats.dataset import RawDataset

REAL = Path(__file__).parent / "data" / "real" / "ck_acc_mag"


@pytest.fixture(scope="module")
def ck():
    return importlog.import_log(str(REAL / "acc_mag_log.csv"), sensor.load(str(REAL / "sensor.toml")))[0]


def _warming(ds, keep=("a", "m")):
    n = len(ds)
    cols = {k: v for k, v in ds.columns.items() if k[0] in keep}
    cols["temp_c"] = 20.0 + 6.0 * (1.0 - np.exp(-np.arange(n) / (n / 3.0)))  # a board warming up
    return RawDataset(cols, dict(ds.meta))


@pytest.mark.parametrize("keep", [("a", "m"), ("a",)])
def test_a_changing_temperature_without_poses_is_said_not_fitted(ck, keep):
    _, rep = calib.fit(_warming(ck, keep))
    (note,) = [x for x in rep.notes if x.startswith("temperature terms not fitted")]
    assert "temp_c spans 5.7 degC" in note and "needs the turntable's poses and both triads" in note


def test_no_temperature_column_no_note(ck):
    _, rep = calib.fit(ck)
    assert not [x for x in rep.notes if x.startswith("temperature terms")]


@pytest.mark.parametrize("span", [0.998, 1.2])
def test_calibrate_says_diagnose_tests_the_temperature_only_when_diagnose_does(ck, span):
    """A barometer's temperature on a hand-held log spanned 0.998 degC:
    calibrate said diagnose tests the residual against temp_c, and diagnose
    said temp_c does not change enough to test (each had its own 1 degC)."""
    from inclino.diagnose.analysis import diagnose

    n = len(ck)
    cols = dict(ck.columns)
    cols["temp_c"] = 24.8 + span * np.arange(n) / (n - 1)
    ds = RawDataset(cols, dict(ck.meta))
    _, rep = calib.fit(ds)
    (note,) = [x for x in rep.notes if x.startswith("temperature terms not fitted")]
    says_tested = "inclino diagnose tests it against temp_c" in note
    untested = [x for x in diagnose(ds).baseline["selection"]["not_testable"] if x["effect"].startswith("temperature")]
    assert says_tested == (not untested) == (span >= 1.0)
    if untested:
        assert "1 degC or more" in note and "1 degC or more" in untested[0]["reason"]
