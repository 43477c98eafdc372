"""Calibration download and verify over the probe's serial link.

download: check the file, write the image into the inactive flash slot (the
probe refuses an image for another serial unless forced), read it back and
compare, activate (the probe's answer names the slot and sequence now in
use).  IDENTIFY is asked first only when the file names no probe serial.  Nothing is written when the file is refused; a failure part-way
leaves the probe on its previous calibration (the probe only switches at the
activation, docs/flash.md).  A broken exchange is retried from the start once
(`attempts`), and the result says what happened.

verify: the stored bytes are the file's, and the probe's corrected output on
raw readings it takes now equals, bit for bit, what the host predicts from the
file through the same firmware C (inclino.engines.firmware).
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

from inclino.engines import firmware as core
from inclino.link import protocol
from inclino.formats.calfile import Calibration
from inclino.formats.calimage import CRC_OFFSET, CalImage
from inclino.errors import CalibrationError
from inclino.link.serial_link import ProbeError, ProbeInBootloader, ProbeLink, ProbeNak
from inclino.formats.jsonout import dumps

COEF = slice(20, CRC_OFFSET)  # the coefficient bytes of a version 2 image


def _coef(image: bytes) -> slice:
    """The bytes of an image that come from the calibration file: the
    temperature order and t_ref (version 2; 0 in version 1) and every
    coefficient, up to the CRC (not the serial, time or method)."""
    return slice(17, len(image) - 4)
SLOT_NAMES = {0: "A", 1: "B", 0xFF: "none"}
# calimg_parse's check codes (calimg.h), the detail of an E_IMAGE refusal
IMAGE_CHECKS = {1: "wrong length", 2: "not a calibration image (magic)", 3: "another image format version",
                4: "CRC mismatch (the image was corrupted)", 5: "a coefficient outside the range the probe accepts"}


def report_refusal(cal: Calibration) -> str | None:
    """Why a calibration must not be downloaded without --force: its own fit
    report says it did not pass.  None when it passed or has no report."""
    rep = cal.report
    if not isinstance(rep, dict) or rep.get("passed", True) is not False:
        return None
    reasons = rep.get("reasons")
    why = "; ".join(str(r) for r in reasons[:3]) if isinstance(reasons, list) and reasons else "no reason given"
    return f"the calibration's own report did not pass ({why})"


def _serial_of(cal: Calibration) -> int | None:
    s = str(cal.probe_serial or "").strip()
    if not s:
        return None
    try:
        v = int(s, 0)
    except ValueError:
        raise CalibrationError(f"probe serial {s!r} in the calibration file is not a number")
    if not 0 <= v < 2**32:
        raise CalibrationError(f"probe serial {v} does not fit 32 bits")
    return v


def build_image(cal: Calibration, probe_serial: int, when: int | None = None) -> bytes:
    """The image for this probe (docs: calimg.h): version 2 (192 bytes)
    when the file's temperature terms are applied by the firmware, else
    version 1 (120 bytes)."""
    method = cal.method if cal.method in ("identity", "ren2014", "li2021", "guo2009", "joint") else "joint"
    t = int(time.time()) if when is None else int(when)
    fixed = cal.to_fixed()
    _check_diagonals(fixed)
    return CalImage(fixed, probe_serial, t, method).pack()


def _check_diagonals(fixed) -> None:
    """The probe refuses an image whose matrix has a diagonal element below
    1/4 (calimg.c, DIAG_MIN: E_IMAGE, 'a coefficient outside the range'):
    say here which element and what it means, before anything is written."""
    from inclino.formats.calfile import M_FRAC
    from inclino.formats.calimage import DIAG_MIN

    for name in ("acc_m", "mag_m"):
        m = getattr(fixed, name)
        for i in range(3):
            if m[4 * i] < DIAG_MIN:
                raise CalibrationError(
                    f"{name}[{i}][{i}] is {m[4 * i] / 2**M_FRAC:.4g}: the probe takes a diagonal element of at "
                    f"least {DIAG_MIN / 2**M_FRAC:g} (a negative one is a mirrored axis, one near 0 a swapped "
                    f"one: the file is for another axis convention or was edited); nothing written")


@dataclass
class DownloadResult:
    ok: bool
    slot: str = ""
    sequence: int = 0
    image_crc: int = 0
    attempts: int = 0
    retries: int = 0
    bytes_out: int = 0
    bytes_in: int = 0
    events: list = field(default_factory=list)

    def to_json(self) -> str:
        """CRCs as upper-case hex strings, zero-padded to their width (as
        `identify --json` and `flash --json` write them)."""
        return dumps({**asdict(self), "image_crc": f"{self.image_crc:04X}"})


def download(link: ProbeLink, cal: Calibration, force: bool = False, when: int | None = None,
             attempts: int = 2, progress=None) -> DownloadResult:
    """Write, read back, activate and confirm a calibration.  Raises
    CalibrationError (nothing written) for a refused file, ProbeError when
    the probe cannot be reached or the last attempt failed."""
    cal.check()
    refusal = report_refusal(cal)
    if refusal and not force:
        raise CalibrationError(f"{refusal}; nothing written (use --force to download it anyway)")
    file_serial = _serial_of(cal)
    res = DownloadResult(ok=False)
    if refusal:
        res.events.append(f"downloaded with --force although {refusal}")
    stage = {"name": ""}

    def step(name):
        stage["name"] = name
        if progress:
            progress(name)

    try:
        return _download_attempts(link, cal, force, when, attempts, res, file_serial, step)
    except KeyboardInterrupt as e:
        raise KeyboardInterrupt("; ".join(x for x in (str(e), _interrupted_at(stage["name"])) if x)) from None


def _interrupted_at(stage: str) -> str:
    """What a Ctrl-C during a download left: the probe switches only at the
    activation (docs/flash.md), so before it the old calibration stands."""
    if stage in ("activate", "confirm"):
        return ("the activation was sent: the probe holds the new calibration or, if it did not get it, its "
                "previous one (inclino identify tells which)")
    return "nothing activated: the probe keeps its previous calibration"


def _download_attempts(link, cal, force, when, attempts, res, file_serial, step) -> DownloadResult:
    last_err: Exception | None = None
    r0, o0, i0 = link.stats.retries, link.stats.bytes_out, link.stats.bytes_in
    for attempt in range(1, attempts + 1):
        res.attempts = attempt
        try:
            step("identify")
            serial = file_serial if file_serial is not None else link.identify().serial
            image = build_image(cal, serial, when)
            step("write")
            try:
                slot, seq, crc = link.cal_write(image, force=force)
            except ProbeNak as e:
                if e.code == 10:
                    raise CalibrationError("the probe refused the file: it is for another probe serial; "
                                           "nothing written (use --force to override)")
                if e.code == 9:
                    why = IMAGE_CHECKS.get(e.detail, f"check code {e.detail}")
                    raise CalibrationError(f"the probe refused the image: {why}; nothing written")
                raise
            step("read back")
            rslot, _valid, rseq, stored = link.cal_read(slot)
            if rslot != slot or rseq != seq or stored != image:
                res.events.append(f"read-back of slot {SLOT_NAMES.get(slot)} differs: not activated")
                raise ProbeError("the calibration read back from the probe differs from what was sent; "
                                 "the probe keeps its previous calibration")
            step("activate")
            aslot, aseq = link.cal_activate(slot, seq)
            step("confirm")
            if (aslot, aseq) != (slot, seq):
                raise ProbeError("after activation the probe does not report the new calibration")
            res.ok, res.slot, res.sequence, res.image_crc = True, SLOT_NAMES.get(slot, str(slot)), seq, crc
            if attempt > 1:
                res.events.append(f"attempt {attempt} succeeded")
            res.retries = link.stats.retries - r0
            res.bytes_out, res.bytes_in = link.stats.bytes_out - o0, link.stats.bytes_in - i0
            return res
        except (CalibrationError, ProbeInBootloader):
            raise
        except ProbeNak as e:
            res.events.append(f"attempt {attempt}: {_nak_event(e)}")
            last_err = e
            if e.code != 11:  # E_STATE (e.g. the probe restarted between write and activate): retry
                break
        except ProbeError as e:
            res.events.append(f"attempt {attempt}: {e}")
            last_err = e
    res.retries = link.stats.retries - r0
    raise ProbeError(f"calibration download failed after {res.attempts} attempt(s): {last_err}; "
                     "the probe keeps the calibration it reports with `inclino identify`") from None


def _nak_event(e: ProbeNak) -> str:
    """A refusal during a download, worded for the log: E_STATE at the
    activation is a probe that restarted after the write (the pending slot
    lives in RAM, docs/flash.md) -- the next attempt writes it again."""
    if e.code == 11 and e.cmd == protocol.CMD["CAL_ACTIVATE"]:
        return (f"{e}: the probe restarted before its activation was done (power lost or reset) "
                "and forgot the written slot; its calibration was unchanged")
    return str(e)


@dataclass
class VerifyResult:
    storage_ok: bool
    correction_ok: bool
    slot: str
    sequence: int
    checks: int
    mismatches: list = field(default_factory=list)   # one short line each
    details: list = field(default_factory=list)      # every differing field, with the raw counts

    @property
    def ok(self) -> bool:
        return self.storage_ok and self.correction_ok

    def to_json(self) -> str:
        return dumps({**asdict(self), "ok": self.ok})


def survey_with_raw(link: ProbeLink) -> tuple[protocol.SurveyRecord, protocol.RawRecord]:
    p = link.request("SURVEY_RAW", timeout=max(link.timeout, 2.0))
    n = protocol.SurveyRecord.FMT.size
    return protocol.SurveyRecord.unpack(p[:n]), protocol.RawRecord.unpack(p[n:])


def verify(link: ProbeLink, cal: Calibration, surveys: int = 3) -> VerifyResult:
    if surveys < 1:   # 0 surveys would "pass" a correction nobody checked
        from inclino.errors import DataError

        raise DataError(f"verify needs at least 1 survey, not {surveys}")
    cal.check()
    fixed = cal.to_fixed()
    ident = link.identify()
    res = VerifyResult(False, False, SLOT_NAMES.get(ident.cal_slot, "?"), ident.cal_sequence, 0)
    if ident.cal_slot == 0xFF:
        res.mismatches.append("the probe has no calibration (it runs the identity calibration): download "
                              "this file with inclino download first")
        return res      # nothing to compare the probe's output with: not checked
    slot, valid, _seq, stored = link.cal_read(ident.cal_slot)
    want = CalImage(fixed, 0, 0, "joint").pack()
    if not valid:
        res.mismatches.append(f"slot {res.slot} is not valid")
    elif len(stored) != len(want) or stored[_coef(want)] != want[_coef(want)]:
        res.mismatches.append(f"the coefficients stored in slot {res.slot} are not the file's")
    else:
        try:
            CalImage.unpack(stored)
            res.storage_ok = True
        except CalibrationError as e:
            res.mismatches.append(f"slot {res.slot}: {e}")
    ok = True
    for n in range(1, surveys + 1):
        s, r = survey_with_raw(link)
        res.checks += 1
        if fixed.temp is not None and r.temp_q6 is None:
            ok = False
            res.mismatches.append(f"survey {n}: the probe's raw record has no temperature at the firmware's "
                                  "resolution (firmware before image version 2): the temperature terms cannot "
                                  "be checked")
            continue
        # survey_compute_temp with the temperature the probe used (the terms
        # of an image without them: survey_compute's bits)
        t = None if r.temp_q6 is None else [r.temp_q6]
        o = core.survey([[r.ax, r.ay, r.az]], [[r.mx, r.my, r.mz]], fixed, temp_q6=t)
        want = {k: int(o[k][0]) for k in core.ATT_COLS}
        got = {"inc": s.inc, "azi": s.azi, "gtf": s.gtf, "mtf": s.mtf, "gt": s.gt, "bt": s.bt, "dip": s.dip,
               "flags": s.flags}
        bad = [k for k, v in got.items() if int(want[k]) != int(v)]
        for k in bad:
            res.details.append(f"survey {n} {k}: probe {got[k]}, file predicts {int(want[k])} (raw {r})")
        if bad:
            ok = False
            res.mismatches.append(f"survey {n}: {', '.join(bad)} differ from what the file predicts")
    res.correction_ok = ok
    return res
