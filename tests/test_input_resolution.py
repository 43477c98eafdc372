"""The input resolution a calibration report states: the sensor
description's lsb, else the step an imported log's values lie on, never the
ADIS16210's for a sensor that is not one (a SunDevilRocketry IMU logged in
m/s2 was reported at 6.1e-05 g per count, "the ADIS16210's assumed", where
its values lie on 1/2048 g)."""
import numpy as np
import pytest

from inclino.calib.report import input_lsb, logged_step
from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset


def _acc(v, meta):
    return RawDataset({"ax_g": v[:, 0], "ay_g": v[:, 1], "az_g": v[:, 2]}, meta)


def _tumbled(rng, n=2000):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True) + rng.normal(scale=2e-3, size=(n, 3))


@pytest.mark.parametrize("lsb", [1 / 2048, 1 / 16384, 0.01 / 9.80665])
def test_counts_times_an_lsb_give_that_lsb(rng, lsb):
    v = np.round(_tumbled(rng) / lsb) * lsb
    step, on = logged_step(v)
    assert on and step == pytest.approx(lsb, rel=1e-6)
    a, m, whence = input_lsb(_acc(v, {"sensor": "a part"}))
    assert a == pytest.approx(lsb, rel=1e-6) and m is None
    assert "the step the logged values lie on" in whence and "ADIS16210" not in whence.split(";")[0]


def test_floats_finer_than_their_noise_have_no_step(rng):
    a, _, whence = input_lsb(_acc(_tumbled(rng), {"sensor": "a phone"}))
    assert a == 0.0 and "lie on no step" in whence


def test_the_description_wins_and_the_probe_keeps_its_own(rng):
    v = np.round(_tumbled(rng) * 2048) / 2048
    assert input_lsb(_acc(v, {"sensor": "a part", "acc_lsb_g": 1e-4}))[0] == 1e-4
    a, _, whence = input_lsb(_acc(v, {}))  # the probe's own run: no sensor description
    assert a is None and "ADIS16210" in whence and f"{ref.ACC_LSB_G:.4g}" in whence


def test_the_calibrate_report_states_the_step_found(rng, tmp_path, capsys):
    from inclino.cli import main
    from inclino.formats.dataset import write_raw

    v = np.round(_tumbled(rng, 600) * 2048) / 2048
    run = tmp_path / "run.csv"
    write_raw(str(run), _acc(v, {"sensor": "a part read at +-16 g"}))
    assert main(["calibrate", str(run), "-o", str(tmp_path / "cal.json")]) in (0, 1)
    out = capsys.readouterr().out
    assert "acc 0.0004883 g per count (the step the logged values lie on)" in out, out


def test_means_of_n_counts_give_n_times_their_step(rng):
    # each row the mean of 25 readings of a part counting 1/2048 g (michaelwro/accelerometer-calibration's
    # record-data.py): the means lie on 1/51200 g, and that step is the count over 25, not the count
    lsb, n = 1 / 2048, 25
    v = np.round((_tumbled(rng)[:, None, :] + rng.normal(scale=3e-3, size=(2000, n, 3))) / lsb).mean(axis=1) * lsb
    step, on = logged_step(v)
    assert on and step == pytest.approx(lsb / n, rel=1e-6)
    a, _, whence = input_lsb(_acc(v, {"sensor": "a part", "samples_averaged": n}))
    assert a == pytest.approx(lsb, rel=1e-6) and "each a mean of 25 counts" in whence
    # one sample a row: the step is the count
    assert input_lsb(_acc(np.round(_tumbled(rng) / lsb) * lsb, {"sensor": "a part", "samples_averaged": 1}))[0] \
        == pytest.approx(lsb, rel=1e-6)
