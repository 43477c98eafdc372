"""Calibration coefficients: float model, fixed-point image, JSON file.

The model, per triad, is the 12-parameter correction both papers fit:
corrected = M @ (raw - b), raw in nominal units (g for the accelerometer,
nT for the fluxgate), M a 3x3 and b a 3-vector in the same units.
The firmware holds M in Q29 (|m| < 4) and b in Q29 g / Q10 nT
(firmware/include/inclino/correct.h).

CAL.json (format 1) holds the float coefficients (acc_m, acc_b, mag_m,
mag_b), their fixed-point image ("fixed", written from the floats), the
method, the probe serial and, for a fitted calibration, "data" (the hash of
the dataset it was fitted from) and "report" (the fit report,
inclino.calib.report.FitReport as a JSON object).  "data" and "report" are
optional (as is "temperature", the temperature terms of joint
--temperature-terms, inclino.calib.thermal) and were added without changing the format number: a reader of the
first files ignores them, and this reader accepts files without them.  When
a file carries "fixed", it must equal the image of its floats (a hand-edited
float with a stale image is refused).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from inclino.engines.firmware import FixedCal
from inclino.errors import CalibrationError

FORMAT_VERSION = 1
TRIADS = ("both", "acc", "mag")
M_FRAC = 29
ACC_B_FRAC = 29  # Q29 g
MAG_B_FRAC = 10  # Q10 nT
M_LIMIT = 4.0
ACC_B_LIMIT = 2.0  # g
MAG_B_LIMIT = 2.0**20  # nT
COND_LIMIT = 1e3


def _q(x, frac, lo, hi, what):
    v = np.round(np.asarray(x, dtype=float) * 2.0**frac)
    if not np.all(np.isfinite(v)) or v.min() < lo or v.max() > hi:
        raise CalibrationError(f"{what} out of the firmware's range")
    return tuple(int(t) for t in v.ravel())


@dataclass
class Calibration:
    acc_m: list = field(default_factory=lambda: np.eye(3).tolist())
    acc_b: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    mag_m: list = field(default_factory=lambda: np.eye(3).tolist())
    mag_b: list = field(default_factory=lambda: [0.0, 0.0, 0.0])
    method: str = "identity"
    probe_serial: str = ""
    format: int = FORMAT_VERSION
    # {"sha256": hex digest, "of": what was hashed, "rows": n} (optional)
    data: dict | None = None
    # the fit report as a JSON object (inclino.calib.report.FitReport) (optional)
    report: dict | None = None
    # temperature terms (inclino.calib.thermal; joint --temperature-terms) (optional;
    # the firmware does not apply them)
    temperature: dict | None = None
    # which triads the calibration holds: "both", or "acc" / "mag" when it was
    # fitted from a one-triad dataset (the other triad's coefficients are then
    # the identity, a placeholder that corrects nothing) (optional: "both")
    triads: str = "both"

    def check(self) -> None:
        """Raise CalibrationError for a matrix that is not 3x3, not finite,
        singular or ill-conditioned, or out of the firmware's range."""
        for name in ("acc_m", "mag_m"):
            m = _array(getattr(self, name), name, "a finite 3x3 matrix")
            if m.shape != (3, 3) or not np.all(np.isfinite(m)):
                raise CalibrationError(f"{name} must be a finite 3x3 matrix")
            c = np.linalg.cond(m)
            if not math.isfinite(c) or c > COND_LIMIT:
                raise CalibrationError(f"{name} is singular or ill-conditioned (cond {c:.3g})")
            if np.abs(m).max() >= M_LIMIT:
                raise CalibrationError(f"{name} has an element beyond +-{M_LIMIT:g}")
        for name, lim in (("acc_b", ACC_B_LIMIT), ("mag_b", MAG_B_LIMIT)):
            b = _array(getattr(self, name), name, "3 finite numbers")
            if b.shape != (3,) or not np.all(np.isfinite(b)):
                raise CalibrationError(f"{name} must be 3 finite numbers")
            if np.abs(b).max() >= lim:
                raise CalibrationError(f"{name} beyond +-{lim:g}")

    def to_fixed(self) -> FixedCal:
        self.check()
        lim = 2**31 - 1
        return FixedCal(
            acc_m=_q(self.acc_m, M_FRAC, -lim, lim, "acc_m"),
            acc_b=_q(self.acc_b, ACC_B_FRAC, -lim, lim, "acc_b"),
            mag_m=_q(self.mag_m, M_FRAC, -lim, lim, "mag_m"),
            mag_b=_q(self.mag_b, MAG_B_FRAC, -lim, lim, "mag_b"),
            temp=self.fixed_temp(),
        )

    def fixed_temp(self):
        """The temperature terms in the firmware's form (inclino.formats.caltemp)
        when the temperature block says the firmware applies them
        (applied_by_firmware: image version 2), else None (version 1)."""
        t = self.temperature
        if not isinstance(t, dict) or t.get("applied_by_firmware") is not True:
            return None
        from inclino.formats import caltemp

        check_temperature(t)
        return caltemp.to_fixed(t)

    @staticmethod
    def from_fixed(fc: FixedCal, **kw) -> "Calibration":
        """The float values a fixed-point image stands for (dequantised)."""
        return Calibration(
            acc_m=(np.array(fc.acc_m, float) / 2**M_FRAC).reshape(3, 3).tolist(),
            acc_b=(np.array(fc.acc_b, float) / 2**ACC_B_FRAC).tolist(),
            mag_m=(np.array(fc.mag_m, float) / 2**M_FRAC).reshape(3, 3).tolist(),
            mag_b=(np.array(fc.mag_b, float) / 2**MAG_B_FRAC).tolist(),
            **kw,
        )

    def to_json(self) -> str:
        d = asdict(self)
        for k in ("data", "report", "temperature"):
            if d[k] is None:
                del d[k]
        if d["triads"] == "both":  # as every file before one-triad calibrations
            del d["triads"]
        d["fixed"] = asdict(self.to_fixed())
        if d["fixed"]["temp"] is None:  # image version 1: as before the temperature terms
            del d["fixed"]["temp"]
        return json.dumps(d, indent=2)

    def save(self, path: str, inputs=()) -> None:
        """Write CAL.json through inclino.formats.safeio: atomically (a temporary file
        renamed into place, so a failure never leaves a half-written file),
        never over one of `inputs`, readable like any other output file."""
        from inclino.formats import safeio

        text = self.to_json() + "\n"  # checks and quantises before any write
        safeio.write_output(path, text, inputs)

    @staticmethod
    def from_json(text: str) -> "Calibration":
        from inclino.formats import safeio

        d = safeio.parse_json(text, "calibration file", CalibrationError)
        if not isinstance(d, dict):
            raise CalibrationError("calibration file must hold a JSON object")
        if d.get("format") != FORMAT_VERSION:
            raise CalibrationError(f"calibration format {str(d.get('format'))[:20]!r} is not {FORMAT_VERSION}")
        from inclino.formats.fields import Fields

        f = Fields(d, "calibration file", CalibrationError)
        cal = Calibration(
            acc_m=f.numbers("acc_m", (3, 3)).tolist(),
            acc_b=f.numbers("acc_b", (3,)).tolist(),
            mag_m=f.numbers("mag_m", (3, 3)).tolist(),
            mag_b=f.numbers("mag_b", (3,)).tolist(),
            method=str(f.string("method", required=False, default="", null=True) or ""),
            probe_serial=_serial_text(d.get("probe_serial", "")),
            data=d.get("data") if isinstance(d.get("data"), dict) else None,
            report=d.get("report") if isinstance(d.get("report"), dict) else None,
            temperature=check_temperature(d["temperature"]) if d.get("temperature") is not None else None,
            triads=f.string("triads", required=False, default="both", choices=TRIADS),
        )
        cal.check()
        if "fixed" in d:
            fx = Fields(d["fixed"], "calibration file: fixed", CalibrationError)
            kw = {}
            for k, n in (("acc_m", 9), ("acc_b", 3), ("mag_m", 9), ("mag_b", 3)):
                v = fx.d.get(k)
                if not isinstance(v, list) or len(v) != n:
                    raise CalibrationError(f"calibration file's fixed-point image is mangled ({k} must be a list "
                                           f"of {n} integers)")
                try:
                    kw[k] = tuple(_fixed_int(x) for x in v)
                except (TypeError, ValueError) as e:
                    raise CalibrationError(f"calibration file's fixed-point image is mangled ({k}: {e})") from None
            fixed = FixedCal(**kw)
            want = cal.to_fixed()
            if isinstance(d["fixed"], dict) and "temp" in d["fixed"]:
                fixed = replace(fixed, temp=_fixed_temp(d["fixed"]["temp"]))
            if fixed != want:
                raise CalibrationError("calibration file's fixed-point image does not match its float coefficients")
        return cal

    @staticmethod
    def load(path: str) -> "Calibration":
        """Read CAL.json: at most safeio.MAX_JSON_BYTES of UTF-8 text (a BOM
        is dropped); a binary, non-UTF-8, too deep or out-of-range file is one
        CalibrationError line."""
        from inclino.formats import safeio

        text = safeio.read_text(path, "calibration", error=CalibrationError)
        try:
            return Calibration.from_json(text)
        except CalibrationError as e:
            raise CalibrationError(f"{path}: {e}") from None


def _serial_text(v) -> str:
    """The probe serial as the file gives it (text, or a JSON integer)."""
    if isinstance(v, bool) or not isinstance(v, (str, int)) or len(str(v)) > 40:
        raise CalibrationError(f"calibration file: probe_serial must be text or an integer, not "
                               f"{str(v)[:20]!r}")
    return str(v)


# the temperature block's terms (inclino.calib.thermal): per unit, the largest magnitude a term may have
TEMP_TERM_LIMIT = {"acc": {"bias": 1.0, "scale_ppm": 1e5}, "mag": {"bias": 1e5, "scale_ppm": 1e5}}


def check_temperature(block) -> dict:
    """CAL.json's temperature block (image version 2 when the firmware
    applies it): structure, types and ranges of every field the readers use
    (CalibrationError naming the field); returns the block."""
    from inclino.formats.fields import Fields

    f = Fields(block, "calibration file: temperature", CalibrationError)
    order = f.integer("order", 0, 2)
    f.number("t_ref_c", -100.0, 300.0)
    if f.has("span_c"):
        f.numbers("span_c", (2,), -100.0, 300.0)
    f.boolean("applied_by_firmware", required=False)
    for tri, lim in TEMP_TERM_LIMIT.items():
        t = f.obj(tri)
        for k, v in lim.items():
            t.numbers(k, (order, 3), -v, v)
    sig = f.obj("sigma", required=False, null=True)
    if sig is not None:
        for tri, lim in TEMP_TERM_LIMIT.items():
            t = sig.obj(tri)
            for k, v in lim.items():
                t.numbers(k, (order, 3), 0.0, v)
    if f.has("covariance") and f.d["covariance"] is not None:
        f.numbers("covariance", (12 * order, 12 * order))
    if f.has("firmware") and not isinstance(f.d["firmware"], dict):
        raise CalibrationError("calibration file: temperature: firmware must be a JSON object")
    return block


FIXED_TEMP_FIELDS = {"t_ref": None, "order": None, "acc_c1": 2**31, "acc_c2": 2**15, "acc_r1": 2**31,
                     "acc_r2": 2**15, "mag_c1": 2**31, "mag_c2": 2**15, "mag_r1": 2**31, "mag_r2": 2**15}


def _fixed_temp(ft):
    """The fixed-point image's temperature terms ("fixed": {"temp": ...})."""
    from inclino.engines.firmware import FixedTemp
    from inclino.formats.fields import Fields

    f = Fields(ft, "calibration file: fixed: temp", CalibrationError)
    f.known(*FIXED_TEMP_FIELDS)
    kw = {"t_ref": f.integer("t_ref", -2**15, 2**15 - 1), "order": f.integer("order", 1, 2)}
    for k, lim in FIXED_TEMP_FIELDS.items():
        if lim is None:
            continue
        v = f.d.get(k)
        if not isinstance(v, list) or len(v) != 3:
            raise CalibrationError(f"calibration file: fixed: temp: {k} must be a list of 3 integers")
        try:
            kw[k] = tuple(_fixed_int(x) for x in v)
        except (TypeError, ValueError) as e:
            raise CalibrationError(f"calibration file: fixed: temp: {k}: {e}") from None
        if any(not -lim <= x < lim for x in kw[k]):
            raise CalibrationError(f"calibration file: fixed: temp: {k} beyond {lim.bit_length()} bits")
    return FixedTemp(**kw)


def _array(value, name: str, what: str) -> np.ndarray:
    """A coefficient as a float array; a ragged or non-numeric one is a
    CalibrationError (never numpy's ValueError)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"{name} must be {what}") from None


def _short(e: Exception) -> str:
    t = str(e)
    return t if len(t) <= 80 else t[:77] + "..."


def _fixed_int(v) -> int:
    """One coefficient of the fixed-point image: an integer (JSON integers
    or a float with an integral value, within int32; 2.5 or "7" is refused)."""
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, int):
        raise TypeError(f"{str(v)[:20]} is not an integer")
    if not -2**31 <= v < 2**31:
        raise ValueError(f"{str(v)[:20]} is beyond 32 bits")
    return v
