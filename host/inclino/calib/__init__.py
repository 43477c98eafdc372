"""Calibration fitting: the three papers' methods and ours.

    from inclino.calib import fit
    cal, report = fit(dataset, "joint")

`fit(ds, method, **opts) -> (Calibration, FitReport)`; methods: joint (the
default), ren2014, li2021, guo2009.  The Calibration carries the method, the
probe serial, the data's hash and the report; `cal.save(path)` writes
CAL.json atomically.  Errors: DataError (bad or insufficient data, exit 2),
CalibrationError (singular or out-of-range result, exit 3).

The submodules (SciPy among their imports) load on first use, so that the
`inclino` command, which registers `calibrate`, starts quickly.
"""
from __future__ import annotations

import importlib
import time

METHODS = ("joint", "ren2014", "li2021", "guo2009")
DEFAULT_METHOD = "joint"
# A longer run is thinned (stratified random rows) before the fit
# (inclino.formats.dataset.thin; peak memory about 12 kB per fitted row in joint)
MAX_FIT_ROWS = 40_000

__all__ = ["fit", "FitReport", "METHODS", "DEFAULT_METHOD"]


def __getattr__(name):
    if name == "FitReport":
        from .report import FitReport

        return FitReport
    raise AttributeError(name)


def fit(ds, method: str = DEFAULT_METHOD, data_hash: dict | None = None, report: bool = True,
        max_rows: int | None = MAX_FIT_ROWS, check: bool = True, static: bool = False, found=None, **opts):
    """found: the checks before the fit (checks.CheckReport) already run on
    these very rows (`inclino diagnose` ran them): used, not run again."""
    import numpy as np

    from inclino.formats.dataset import thin

    from inclino.errors import CalibrationError, DataError

    from . import common
    from . import report as report_mod

    if method not in METHODS:
        raise DataError(f"unknown calibration method {method!r} (one of {', '.join(METHODS)})")
    if len(ds) == 0:
        raise DataError("the dataset has no rows")
    mod = importlib.import_module(f"inclino.calib.{method}")
    data_hash = data_hash or common.dataset_hash(ds)  # of every row, before thinning
    from inclino.holds import declared_static

    if static and not declared_static(ds):
        import dataclasses

        # declared here (calibrate --static): the checks, and the holds (inclino.holds), read it from the header
        ds = dataclasses.replace(ds, meta={**ds.meta, "static": "true"})
    found = None
    if check:  # inclino.checks: data that cannot be right stop here (DataError, exit 2), before any fit
        from inclino import checks

        if found is None or found.rows != len(ds):
            found = checks.run(ds, declared_static=static)
        found.raise_errors()
        if found.one_orientation:  # one orientation held: no triad's scale, offsets or axes show (exit 3)
            raise CalibrationError("singular fit refused: " + checks.undetermined(found.one_orientation, len(ds)))
        if found.saturated:  # readings at the declared range are not readings of the field
            keep = np.setdiff1d(np.arange(len(ds)), found.saturated)
            ds = common.subset(ds, keep)
        if found.mag_to_acc is not None and method == "joint":
            opts.setdefault("mag_start", found.mag_to_acc)
    ds, thinned = thin(ds, max_rows)
    if ds.triads != "both":  # one triad: calib.single (joint only: the papers' methods need both)
        if method != "joint":
            raise DataError(f"{method} fits both triads; this is an "
                            f"{'accelerometer' if ds.has_acc else 'magnetometer'}-only dataset (--method joint)")
        if opts.get("temperature", "auto") == "on":  # asked for: fitted or refused, never a calibration without them
            raise DataError("joint --temperature-terms on needs both triads (the temperature fit is of the turntable's "
                            f"poses and both triads); this is {'an accelerometer' if ds.has_acc else 'a magnetometer'}"
                            "-only dataset: calibrate it with --temperature-terms auto or off (inclino diagnose "
                            "tests its invariants against temp_c)")
        from . import single

        t0 = time.perf_counter()
        with np.errstate(all="ignore"):
            cal, info = single.fit(ds, **{k: v for k, v in opts.items()
                                          if k in ("use_poses", "mount_tolerance_deg", "accept_mount_tolerance")})
        cal.data = data_hash
        _refuse_reflection(ds, cal, bool(opts.get("use_poses", True)))
        rep = None
        if report:
            rep = report_mod.build_single(ds, cal, info)
            if opts.get("temperature", "auto") != "off":
                from .thermal import not_fitted_without_poses

                note = not_fitted_without_poses(ds)
                if note:
                    rep.notes.append(note)
            rep.fit_time_s = time.perf_counter() - t0
            if thinned:
                rep.notes.append(thinned)
            if found is not None:
                rep.checks = found.to_dict()
                rep.notes += [f"check: {line}" for line in found.lines(("warning",))]
            cal.report = rep.to_dict()
        return cal, rep
    t0 = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            cal, info = mod.fit(ds, **opts)
            if method == "joint" and opts.get("temperature", "auto") != "off":  # calib/thermal.py
                from . import thermal
                from .joint import SIGMA_POSE_DEG

                an = info["assumed_noise"]  # the noise joint.fit assumed
                cal, info = thermal.fit(ds, cal, info, opts.get("temperature", "auto"), an["acc_g"], an["mag_nT"],
                                        opts.get("sigma_pose_deg", SIGMA_POSE_DEG), bool(opts.get("fix_dip")))
    except np.linalg.LinAlgError as e:
        raise CalibrationError(f"{method}: singular fit ({e})")
    elapsed = time.perf_counter() - t0
    cal.data = data_hash
    _refuse_reflection(ds, cal, bool(opts.get("use_poses", True)))
    turned = _refuse_turned_field(ds, cal, found)
    rep_ds = info.pop("report_dataset", ds)  # joint --temperature-terms: the readings brought to t_ref
    rep = None
    if report:
        refit = (lambda d: mod.fit(d, **opts)[0]) if "covariance" not in info else None
        with np.errstate(all="ignore"):
            rep = report_mod.build(rep_ds, cal, method, info, refit, opts)
        rep.fit_time_s = elapsed
        if thinned:
            rep.notes.append(thinned)
        if found is not None:
            rep.checks = found.to_dict()
            rep.notes += [f"check: {line}" for line in found.lines(("warning",))]
            if found.saturated:
                rep.notes.append(f"{len(found.saturated)} saturated row(s) left out of the fit")
        if turned:
            rep.notes.append(f"check: warning: {turned}")
        cal.report = rep.to_dict()
    return cal, rep


def _refuse_reflection(ds, cal, use_poses: bool) -> None:
    """A fitted triad matrix with a negative determinant is a reflection:
    the data's axes of that triad are mirrored against what it was fitted to
    (the poses, or the other triad).  A general 3x3 absorbs it, so the fit
    itself does not fail: BROAD 05 with the magnetometer's x column negated
    fitted to the same residuals as the log as given, with det -1.40, and the
    calibration was written.  Refused (DataError, exit 2; nothing written)
    unless the header declares the reflection intended."""
    import numpy as np

    from inclino.checks import declared_reflection, intended_reflection
    from inclino.errors import MirroredAxesError

    ref = "the poses" if use_poses and ds.has_pose else None
    for triad, name, M in (("acc", "accelerometer", cal.acc_m), ("mag", "magnetometer", cal.mag_m)):
        if not getattr(ds, f"has_{triad}") or intended_reflection(ds, triad):
            continue
        det = float(np.linalg.det(np.asarray(M, float)))
        if det < 0:
            other = "mag" if triad == "acc" else "acc"
            against = ref or ({"acc": "the accelerometer", "mag": "the magnetometer"}[other]
                              if getattr(ds, f"has_{other}") else
                              "the poses" if "inc_deg" in ds.columns else "the frame of the fit")
            fix = (f"the declared reflection ([{name}] reflection = true) does not fit the data as mapped: fix that "
                   f"triad's axis map in the sensor description (one sign, without reflection = true)"
                   if declared_reflection(ds, triad) else
                   "fix that triad's axis map in the sensor description (one sign), or declare the reflection "
                   "intended (reflection = true)")
            raise MirroredAxesError(
                f"the fitted {name} matrix is a reflection (determinant {det:+.3g}): the {name}'s axes in the data "
                f"are mirrored against {against}; {fix}; no calibration written")


def _refuse_turned_field(ds, cal, found) -> str | None:
    """The fitted dip's sign against the header's.  A magnetometer axis
    mirrored in the data is a reflection P of the field; the invariants
    (|g|, |b|, the dip's spread) fit -P, a proper rotation, exactly as well,
    with the dip's sign turned: the MPU9150 log of micropython-fusion with
    its y column negated, which the checks before the fit see only weakly
    (the dip spreads 10.4 deg as given, 3.72 mirrored: a warning, not the 3x
    of an error), fitted det(mag_m) +0.98, a dip of -70.8 deg against the
    header's +66.5, and azimuths 180 deg off.  No determinant and no check
    before the fit sees that; the header's dip does.  Opposite signs (both
    beyond checks.DIP_SIGN_MIN_DEG) are refused (DataError, exit 2; nothing
    written).  The same sign but more than checks.DIP_MISMATCH_DEG apart:
    the warning line to report.  Without a header dip, when the checks before
    the fit warned of a mirror, the warning line to report (else None)."""
    import numpy as np

    from inclino.checks import DIP_MISMATCH_DEG, DIP_SIGN_MIN_DEG
    from inclino.engines import reference as ref
    from inclino.errors import MirroredAxesError

    if ds.triads != "both":
        return None
    with np.errstate(all="ignore"):
        a = ref.attitude(ref.correct(ds.acc, cal.acc_m, cal.acc_b), ref.correct(ds.mag, cal.mag_m, cal.mag_b))
    dip = float(np.nanmedian(a["dip"]))
    mirror = [f for f in (found.findings if found is not None else [])
              if f.check == "handedness" and f.level == "warning"]
    fig = mirror[0].figures if mirror else {}
    hint = ("" if not fig.get("map_to_write") else
            f" (the checks before the fit: magnetometer {fig['map_to_write']}"
            + (f", or {fig['twin_map_to_write']} with the dip's sign turned" if fig.get("twin_map_to_write") else "")
            + ")")
    hdr = ds.meta.get("dip_deg")
    if hdr is not None:
        hdr = float(hdr)
        if min(abs(hdr), abs(dip)) > DIP_SIGN_MIN_DEG and np.sign(dip) != np.sign(hdr):
            det = float(np.linalg.det(np.asarray(cal.mag_m, float)))
            raise MirroredAxesError(
                f"the fitted dip is {dip:+.1f} deg against the header's {hdr:+.1f}: the fit turned the field through "
                f"180 deg (azimuths 180 deg off; magnetometer matrix determinant {det:+.3g}): a magnetometer axis "
                f"mirrored in the data{hint}, or the accelerometer's gravity sign turned (reads); fix that axis map or "
                f"reads in the sensor description and import again; no calibration written")
        if abs(dip - hdr) > DIP_MISMATCH_DEG:
            # the same sign but far off: said after the fit as the checks say it before (a hand-held controller
            # in an office, freeIMUCal's log: fitted dips of +69 and +75 deg on its halves against WMM's +58.6,
            # written without a word; the check before the fit had said +2.7 from its per-triad ellipsoids)
            return (f"the fitted dip is {dip:+.1f} deg against the header's {hdr:+.1f} ({abs(dip - hdr):.1f} deg "
                    f"apart, beyond {DIP_MISMATCH_DEG:g}): a wrong dip_deg, a disturbed field where the run was "
                    f"logged (steel, the device's own parts), or a relative rotation of the triads the run fixes "
                    f"poorly; every azimuth computed with this calibration carries it: check dip_deg (inclino "
                    f"reffield) and log the run away from steel")
        return None
    if mirror:
        return (f"the fitted dip is {dip:+.1f} deg and the magnetometer's axes may be mirrored{hint}: the fit may "
                f"have turned the field through 180 deg (a mirrored axis fitted as a rotation: the dip's sign and "
                f"every azimuth turned), which no header dip checks; give the site's dip ([header] dip_deg, or "
                f"# dip_deg= in the log; inclino reffield) and calibrate again")
    return None
