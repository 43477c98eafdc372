"""Without poses, a log read mostly while moving (a hand turning the
sensor) has the hand's acceleration in its |g| residual: `diagnose` names
that as the likely cause of the structure no effect explains, as
`calibrate` names it beside its failing |g| residual (calib.motion), and
says nothing of it for a log read at rest between turns."""
from pathlib import Path

from inclino.diagnose.analysis import diagnose
from inclino.formats import importlog, sensor

REAL = Path(__file__).parent / "data" / "real"


def _log(name, log):
    return importlog.import_log(str(REAL / name / log), sensor.load(str(REAL / name / "sensor.toml")))[0]


def test_a_hand_turned_log_names_the_motion_in_g():
    r = diagnose(_log("micropython_fusion", "mpudata.csv"))
    assert r.unexplained and r.motion is not None and r.motion["moving_share"] > 0.9
    assert "the hand's acceleration" in r.conclusion()
    assert "in |g| likely: the sensor moved while it was read" in r.summary()
    assert r.to_dict()["motion"]["rows"] == 2041


def test_a_step_and_hold_log_says_nothing_of_motion():
    r = diagnose(_log("mpu6050_tedaldi", "example_data_calibration.csv"))
    assert r.motion is None and "hand's acceleration" not in r.summary()


def test_a_log_calibrate_refuses_is_said_so_by_diagnose():
    """CK's first 1 000 rows turn about the vertical (the accelerometer
    hardly tilts): `calibrate` refuses them, and the pose-free baseline,
    fitted whatever the orientations, must not stand as a model whose
    structure is merely unexplained: diagnose says calibrate refuses them,
    with calibrate's own reason."""
    import numpy as np

    from inclino import calib, checks
    from inclino.calib import common
    from inclino.errors import DataError

    ck = common.subset(_log("ck_acc_mag", "acc_mag_log.csv"), np.arange(1000))
    try:
        calib.fit(ck, "joint", report=False, check=False)
        refused = None
    except DataError as e:
        refused = str(e)
    assert refused is not None and "ellipsoid" in refused
    r = diagnose(ck, checks=checks.run(ck))
    assert r.calibrate["level"] == "error" and r.calibrate["message"] in refused
    assert r.conclusion().startswith("conclusion: FAIL: calibrate refuses these data (the data do not determine")
    assert f"calibrate refuses these data: {r.calibrate['message']}" in r.summary()
