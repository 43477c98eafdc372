"""The emulated probe's firmware removes the temperature dependence its
sensors have: a probe whose tempcos are drawn at test time from the typical
scenario's spread (size and axis unknown to the test) is calibrated from a
chamber run (joint --temperature-terms on), the calibration is downloaded as an
image of version 2, and surveys through the firmware at -5 and 55 degC err
about as much as at 25 degC; without the terms (the same raw readings
through survey_compute) they err more where the effect is visible above
the noise.  The probe's surveys are also what the host predicts, bit for
bit, from its raw records (temperature at the firmware's resolution)."""
import numpy as np

from inclino.formats import caltemp
from inclino.engines import firmware as core
from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration
from inclino.calib import fit, thermal
from inclino.formats.calimage import CalImage
from inclino_emu.probe import EmulatedProbe
from inclino.model.scenario import load_scenario

from test_calib_thermal import chamber_run

POSES = [(i, a, t) for i in (8.0, 30.0, 60.0, 90.0) for a in (20.0, 110.0, 200.0, 290.0) for t in (0.0, 135.0)]


def _errors(p, fc, fc_plain, cal):
    """Azimuth and inclination RMS error (deg) of the firmware's surveys
    against the true attitude, and of the same raw readings without the
    temperature terms; how many surveys the host predicted bit for bit; and
    the largest difference (deg) from float64 applying CAL.json's terms
    (thermal.to_reference) to the same readings at the temperature read."""
    e_with, e_without, exact, d_float = [], [], 0, 0.0
    for inc, azi, tf in POSES:
        p.move_to(inc, azi, tf)
        s = p.survey()
        assert s["status"] == 0
        g, b = p.truth()
        t = ref.attitude(np.atleast_2d(g), np.atleast_2d(b))
        r = s["raw"]
        want = core.survey([r["acc"]], [r["mag"]], fc, temp_q6=[r["temp_q6"]])
        exact += int(all(int(want[k][0]) == s["att_raw"][k] for k in core.ATT_COLS))
        plain = core.survey([r["acc"]], [r["mag"]], fc_plain)
        acc = np.atleast_2d(r["acc"]) / 64.0 * ref.ACC_LSB_G
        mag = np.atleast_2d(r["mag"]) / 64.0 * ref.MAG_LSB_NT
        ra, rm = thermal.to_reference(acc, mag, caltemp.q6_to_temp_c([r["temp_q6"]]), cal, cal.temperature)
        fl = ref.attitude(ref.correct(ra, cal.acc_m, cal.acc_b), ref.correct(rm, cal.mag_m, cal.mag_b))
        d_float = max(d_float, abs(ref.angle_diff(s["azi"], fl["azi"][0])), abs(s["inc"] - fl["inc"][0]))
        for out, got_azi, got_inc in ((e_with, s["azi"], s["inc"]),
                                      (e_without, plain["azi"][0] / 65536.0, plain["inc"][0] / 65536.0)):
            out.append((ref.angle_diff(got_azi, t["azi"][0]), got_inc - t["inc"][0]))
    rms = [np.sqrt(np.mean(np.square(np.asarray(e)), axis=0)) for e in (e_with, e_without)]
    return rms[0], rms[1], exact, d_float


def test_firmware_applies_the_temperature_terms_end_to_end(rng):
    sc = load_scenario("typical").draw_tempcos(int(rng.integers(1 << 30)))
    cal, _ = fit(chamber_run(sc, seed=int(rng.integers(1 << 30))), "joint", temperature="on")
    assert cal.temperature["applied_by_firmware"] is True
    fc = cal.to_fixed()
    assert fc.temp is not None
    fc_plain = Calibration(acc_m=cal.acc_m, acc_b=cal.acc_b, mag_m=cal.mag_m, mag_b=cal.mag_b).to_fixed()

    p = EmulatedProbe(sc, seed=int(rng.integers(1 << 30)))
    img = CalImage(fc, p.identity()["serial"], 1_800_000_000, "joint").pack()
    assert len(img) == 192
    assert p.cal_write(img).status == 0 and p.cal_activate().status == 0
    assert p.active_temp()[0] in (1, 2)
    assert p.set_average(64) == 0  # the probe's own noise well below the effect compared
    res = {}
    for temp in (25.0, -5.0, 55.0):
        p.set_temperature(temp)
        w, wo, exact, d_float = _errors(p, fc, fc_plain, cal)
        assert exact == len(POSES), f"{len(POSES) - exact} surveys at {temp} degC not as the host predicts"
        # the firmware applies the file's terms: the fixed-point path within its loss of float64
        # (inclino bench accuracy, temperature section: about 3e-4 deg at these temperatures)
        assert d_float < 0.002, (temp, d_float)
        res[temp] = (w, wo)
    (azi25, inc25), _ = res[25.0]
    floor = 0.02  # deg: the spread of a 32-pose RMS from the probe's noise and the terms' own uncertainty
    for temp in (-5.0, 55.0):
        (azi, inc), (azi_wo, inc_wo) = res[temp]
        assert azi <= max(1.2 * azi25, azi25 + floor), (temp, res)
        assert inc <= max(1.2 * inc25, inc25 + floor), (temp, res)
        # the terms are what removed the effect: without them it shows where it is large
        if azi_wo > azi25 + 5 * floor:
            assert azi < 0.5 * azi_wo, (temp, res)
