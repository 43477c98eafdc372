"""The correction with the calibration's temperature terms, as an engine:
what `inclino accept --temperatures`, the temperature section of `inclino
bench calibration` and `inclino demo --chamber` put the probe's raw
records through (docs/calibration.md, "Temperature terms in the firmware").

An engine takes what the probe's acquisition hands its correction -- the
means of both triads in Q6 counts (golden.IN_ONE = 64 per count) and the
TEMP_OUT mean in Q6 counts (SURVEY_RAW's temp_q6, acquire.h; T = (1331 -
raw) x 0.47 degC, 0.0073 degC per LSB) -- and a Calibration (CAL.json, with
or without its "temperature" block), and returns the survey in the
firmware's fixed point (core.ATT_COLS).

    survey(acc_q6, mag_q6, temp_q6, cal, terms=True) -> dict of int arrays

terms=False is the room-temperature-only calibration of the same probe: the
same M, b without the temperature terms (the firmware's correction with a
version 1 image).

Engines (ENGINES; `get(name)`):

* firmware -- the calibration as the probe holds it: Calibration.to_fixed()
  with the quantised temperature terms (image version 2, inclino.formats.caltemp)
  through the firmware's C (inclino.engines.firmware.survey with temp_q6), bit for bit
  the probe's own survey.  A calibration whose terms the image cannot hold
  (its block says applied_by_firmware false, with why) is refused
  (CalibrationError): the probe would not apply them.
* golden -- the same integers through the NumPy golden model.
* host-terms -- the terms applied on the host in float64 to the Q6 means
  (calib.thermal.to_reference, the CAL.json model with the exact division),
  rounded back to Q6, then the firmware's C with M, b: the correction as it
  was before the firmware applied the terms; kept to compare with, and for
  terms the image cannot hold.

`get("auto")` is firmware when this build's C core has the temperature path
(`firmware_available()`), host-terms otherwise.
"""
from __future__ import annotations

import numpy as np

from inclino.engines import firmware as core
from inclino.engines import reference as ref
from inclino.errors import CalibrationError, DataError

ENGINES = ("auto", "firmware", "golden", "host-terms")
Q6 = 64.0
TEMP_RAW_ZERO = 1331  # TEMP_OUT count at 0 degC (adis16210.h)
TEMP_DEG_PER_COUNT = 0.47


def has_terms(cal) -> bool:
    t = getattr(cal, "temperature", None)
    return isinstance(t, dict) and int(t.get("order", 0)) >= 1


def without_terms(cal):
    """A copy of cal without its temperature block (the room-temperature-only
    calibration: the same M, b)."""
    import copy

    c = copy.deepcopy(cal)
    c.temperature = None
    return c


def temp_c_of(temp_q6) -> np.ndarray:
    """TEMP_OUT mean in Q6 counts -> degC."""
    return (TEMP_RAW_ZERO - np.asarray(temp_q6, float) / Q6) * TEMP_DEG_PER_COUNT


def temp_q6_of(temp_c) -> np.ndarray:
    """The probe's temp_q6 for a true temperature: TEMP_OUT as the emulated
    ADIS16210 gives it (whole counts, raw = round(1331 + T / -0.47), no
    noise to dither it, so the mean of a reading is a whole count), in Q6."""
    raw = np.round(TEMP_RAW_ZERO + np.asarray(temp_c, float) / -TEMP_DEG_PER_COUNT)
    return (raw * Q6).astype(np.int64)


def temp_q6_from_centi(temp_cc) -> np.ndarray:
    """A raw record without temp_q6 (firmware before image version 2): its
    temp_cc is (1331 - raw) x 47 of the whole-count mean, so raw comes back
    exactly."""
    return np.round((TEMP_RAW_ZERO - np.asarray(temp_cc, float) / 47.0) * Q6).astype(np.int64)


def firmware_available() -> bool:
    """The firmware applies the temperature terms (its C core has the
    temperature path: core.FixedTemp, survey(..., temp_q6))."""
    return hasattr(core, "FixedTemp")


def _fixed(cal, terms: bool):
    """cal.to_fixed() with the terms (refused when the image cannot hold
    them) or without."""
    from dataclasses import replace

    fc = cal.to_fixed()
    if not terms:
        return replace(fc, temp=None) if getattr(fc, "temp", None) is not None else fc
    if has_terms(cal) and getattr(fc, "temp", None) is None:
        why = (cal.temperature.get("firmware") or {}).get("why_not", "applied_by_firmware is false")
        raise CalibrationError(f"the firmware cannot apply this calibration's temperature terms ({why}); "
                               "--engine host-terms applies them on the host")
    return fc


class HostTerms:
    name = "host-terms"
    terms_in_firmware = False

    def check(self, cal) -> None:
        pass

    def prepare(self, cal, terms: bool = True):
        """The calibration's fixed-point form this engine's survey uses: a
        caller that surveys window after window with one calibration
        converts it once and passes it as `fixed` (the conversion checks the
        whole temperature block, which costs more than a window's survey)."""
        return _fixed(cal, False)

    def survey(self, acc_q6, mag_q6, temp_q6, cal, terms: bool = True, fixed=None) -> dict:
        acc_q6 = np.atleast_2d(np.asarray(acc_q6, np.int64))
        mag_q6 = np.atleast_2d(np.asarray(mag_q6, np.int64))
        if terms and has_terms(cal):
            from inclino.calib import thermal

            acc = acc_q6 / Q6 * ref.ACC_LSB_G
            mag = mag_q6 / Q6 * ref.MAG_LSB_NT
            T = np.broadcast_to(temp_c_of(temp_q6), (len(acc),))
            a, m = thermal.to_reference(acc, mag, T, cal, cal.temperature)
            acc_q6 = np.floor(a / ref.ACC_LSB_G * Q6 + 0.5).astype(np.int64)
            mag_q6 = np.floor(m / ref.MAG_LSB_NT * Q6 + 0.5).astype(np.int64)
        return core.survey(acc_q6, mag_q6, self.prepare(cal, terms) if fixed is None else fixed)


class Firmware:
    name = "firmware"
    terms_in_firmware = True

    def check(self, cal) -> None:
        _fixed(cal, True)

    def prepare(self, cal, terms: bool = True):
        """As HostTerms.prepare: the image the firmware would hold, with the
        terms or without."""
        return _fixed(cal, terms)

    def survey(self, acc_q6, mag_q6, temp_q6, cal, terms: bool = True, fixed=None) -> dict:
        acc_q6 = np.atleast_2d(np.asarray(acc_q6, np.int64))
        mag_q6 = np.atleast_2d(np.asarray(mag_q6, np.int64))
        tq6 = np.broadcast_to(np.asarray(temp_q6, np.int64), (len(acc_q6),))
        return core.survey(acc_q6, mag_q6, self.prepare(cal, terms) if fixed is None else fixed, temp_q6=tq6)


class Golden(Firmware):
    name = "golden"

    def survey(self, acc_q6, mag_q6, temp_q6, cal, terms: bool = True, fixed=None) -> dict:
        from inclino.engines import golden

        acc_q6 = np.atleast_2d(np.asarray(acc_q6, np.int64))
        mag_q6 = np.atleast_2d(np.asarray(mag_q6, np.int64))
        tq6 = np.broadcast_to(np.asarray(temp_q6, np.int64), (len(acc_q6),))
        fc = self.prepare(cal, terms) if fixed is None else fixed
        return golden.survey_compute(acc_q6, mag_q6, *fc.arrays(), temp=fc.temp, temp_q6=tq6)


def get(name: str = "auto"):
    if name not in ENGINES:
        raise DataError(f"--engine must be one of {', '.join(ENGINES)}")
    if name in ("firmware", "golden") and not firmware_available():
        raise DataError(f"--engine {name}: this build's firmware does not apply the temperature terms")
    if name == "golden":
        return Golden()
    if name == "firmware" or (name == "auto" and firmware_available()):
        return Firmware()
    return HostTerms()


def units(out: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inclination deg, azimuth deg, flags) of an engine's survey."""
    return (np.asarray(out["inc"], float) / 65536.0, np.asarray(out["azi"], float) / 65536.0,
            np.asarray(out["flags"], np.int64))
