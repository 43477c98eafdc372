"""The correction with the calibration's temperature terms, as an engine:
what `inclino accept --temperatures`, the temperature section of `inclino
bench calibration` and `inclino demo --temperature` put the probe's raw
records through (docs/calibration.md, "Temperature terms in the firmware").

An engine takes what the probe's acquisition hands its correction -- the
means of both triads in Q6 counts (golden.IN_ONE = 64 per count) and the
averaged temperature in hundredths of a degree (SURVEY_RAW's temp_cc, i.e.
adis_temp_centi_c of the averaged TEMP_OUT: 0.47 degC steps) -- and a
Calibration (CAL.json, with or without its "temperature" block), and returns
the survey in the firmware's fixed point (core.ATT_COLS).

    survey(acc_q6, mag_q6, temp_cc, cal, terms=True) -> dict of int arrays

terms=False is the room-temperature-only calibration of the same probe: the
same M, b without the temperature terms (the firmware's correction as it
was before the image carried them).

Engines (ENGINES; `get(name)`):

* firmware -- the calibration as the probe holds it: the image the download
  writes (M, b and the quantised temperature terms), through the firmware's
  C (inclino.core), bit for bit the probe's own survey.  Available when the
  firmware applies the terms (`firmware_available()`).
* host-terms -- the terms applied on the host in float64 to the Q6 means
  (calib.thermal.to_reference), rounded back to Q6, then the firmware's C
  with M, b: what the probe computes once the temperature path is in the
  firmware, up to that path's fixed-point rounding.  The stand-in while the
  firmware does not apply the terms; every result names the engine it used
  (`engine`, `terms_in_firmware`).

`get("auto")` is firmware when available, host-terms otherwise.
"""
from __future__ import annotations

import numpy as np

from inclino import core
from inclino import reference as ref
from inclino.errors import DataError

ENGINES = ("auto", "firmware", "host-terms")
Q6 = 64.0


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


def temp_c_of(temp_cc) -> np.ndarray:
    return np.asarray(temp_cc, float) / 100.0


def temp_cc_of(temp_c) -> np.ndarray:
    """The probe's temp_cc for a true temperature: TEMP_OUT rounded to whole
    counts (emulator adis16210: raw = round(1331 + T / -0.47)), then
    adis_temp_centi_c (firmware/src/adis16210.c: (1331 - raw) * 47)."""
    raw = np.round(1331.0 + np.asarray(temp_c, float) / -0.47)
    return ((1331.0 - raw) * 47.0).astype(np.int64)


def firmware_available() -> bool:
    """The firmware applies the temperature terms (its C core has the
    temperature path and the image carries the terms)."""
    return hasattr(core, "survey_temp")


class HostTerms:
    name = "host-terms"
    terms_in_firmware = False

    def survey(self, acc_q6, mag_q6, temp_cc, cal, terms: bool = True) -> dict:
        acc_q6 = np.atleast_2d(np.asarray(acc_q6, np.int64))
        mag_q6 = np.atleast_2d(np.asarray(mag_q6, np.int64))
        if terms and has_terms(cal):
            from inclino.calib import thermal

            acc = acc_q6 / Q6 * ref.ACC_LSB_G
            mag = mag_q6 / Q6 * ref.MAG_LSB_NT
            T = np.broadcast_to(temp_c_of(temp_cc), (len(acc),))
            a, m = thermal.to_reference(acc, mag, T, cal, cal.temperature)
            acc_q6 = np.floor(a / ref.ACC_LSB_G * Q6 + 0.5).astype(np.int64)
            mag_q6 = np.floor(m / ref.MAG_LSB_NT * Q6 + 0.5).astype(np.int64)
        return core.survey(acc_q6, mag_q6, cal.to_fixed())


class Firmware:
    name = "firmware"
    terms_in_firmware = True

    def survey(self, acc_q6, mag_q6, temp_cc, cal, terms: bool = True) -> dict:
        acc_q6 = np.atleast_2d(np.asarray(acc_q6, np.int64))
        mag_q6 = np.atleast_2d(np.asarray(mag_q6, np.int64))
        c = cal if terms else without_terms(cal)
        tcc = np.broadcast_to(np.asarray(temp_cc, np.int64), (len(acc_q6),))
        return core.survey_temp(acc_q6, mag_q6, tcc, c)


def get(name: str = "auto"):
    if name not in ENGINES:
        raise DataError(f"--engine must be one of {', '.join(ENGINES)}")
    if name == "firmware" and not firmware_available():
        raise DataError("--engine firmware: this build's firmware does not apply the temperature terms")
    if name == "firmware" or (name == "auto" and firmware_available()):
        return Firmware()
    return HostTerms()


def units(out: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inclination deg, azimuth deg, flags) of an engine's survey."""
    return (np.asarray(out["inc"], float) / 65536.0, np.asarray(out["azi"], float) / 65536.0,
            np.asarray(out["flags"], np.int64))
