"""`joint` on a one-triad dataset: an accelerometer-only or a
magnetometer-only run calibrates the triad it has.

* With poses (inc_deg and tf_deg; a magnetometer also needs azi_deg and the
  header's dip_deg): the 12-parameter model against the poses' gravity
  (field) in body axes, least squares, robust (calib.triad.fit_poses).  When
  rows repeat poses (a step-and-hold run), the covariance is the larger of
  the row-level one and the pose-level one (the fit to the poses' means,
  scaled by their own scatter): readings at one pose share its placement
  error and are not independent measurements.
* Without poses: the ellipsoid fit (calib.triad.fit_sphere), the triad's
  own axes as the body frame.

The calibration (Calibration.triads = "acc" or "mag") holds the fitted
triad; the other triad's coefficients are the identity.  The report gives
what that triad determines: |g| (|b|) residual, with poses the vector and
inclination residuals, the coefficients' 1-sigma and the inclination they
predict (accelerometer), coverage, conditioning; the verdict judges those.
"""
from __future__ import annotations

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration
from inclino.errors import CalibrationError, DataError

from . import triad
from .common import assumed_noise, field_of, refuse_out_of_range, world_of

MIN_ROWS_POSES = 6
MIN_ROWS_SPHERE = 12


def _poses(ds, kind):
    have = "inc_deg" in ds.columns and "tf_deg" in ds.columns
    if kind == "mag":
        have = have and "azi_deg" in ds.columns
    return have


def _pose_groups(ds):
    cols = [ds.columns[c] for c in ("inc_deg", "azi_deg", "tf_deg") if c in ds.columns]
    key = np.round(np.column_stack(cols), 3)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    return inv.ravel()


def truth(ds, kind, w):
    inc, tf = ds.columns["inc_deg"], ds.columns["tf_deg"]
    azi = ds.columns.get("azi_deg", np.zeros(len(ds)))
    if kind == "acc":
        C = ref.pose_matrix(inc, azi, tf)
        return C[:, :, 2] * w["gravity_g"]
    if w["dip_deg"] is None:
        raise DataError("a magnetometer-only fit with poses needs the field's dip: add a '# dip_deg=...' header line")
    return ref.body_vectors(inc, azi, tf, w["field_nT"], w["dip_deg"], w["declination_deg"], w["gravity_g"])[1]


def _noise_var(raw, keep, groups, tm, M, sigma):
    """Per pose, the variance of its mean reading from the readings' own
    noise, corrected (M): along the truth's direction (radial, (n,)) and
    across it (tangential, (n,), per axis of the plane across it): the rows'
    scatter there over their count (sigma^2 over it for a pose of one row),
    times (1 + rho) / (1 - rho) for the rows' lag-1 correlation rho pooled
    over the poses (a reading that wanders while held averages down more
    slowly)."""
    rad, tan, num, den = np.empty(len(tm)), np.empty(len(tm)), 0.0, 0.0
    for k in range(len(tm)):
        v = raw[keep & (groups == k)] @ M.T
        if not len(v):  # every row of the pose rejected: the pose is left out of the fit to the means
            rad[k] = tan[k] = sigma ** 2
            continue
        u = tm[k] / np.linalg.norm(tm[k])
        d = v - v.mean(0)
        x = d @ u
        num, den = num + float(x[1:] @ x[:-1]), den + float(x @ x)
        n = max(len(x), 1)
        if len(x) > 1:
            rad[k] = float(np.var(x, ddof=1)) / n
            tan[k] = (float(np.sum(d * d)) - float(x @ x)) / (2.0 * (len(x) - 1)) / n
        else:
            rad[k] = tan[k] = sigma ** 2 / n
    rho = min(max(num / den, 0.0), 0.95) if den > 0 else 0.0
    f = (1.0 + rho) / (1.0 - rho)
    return rad * f, tan * f


def world(ds) -> dict:
    """world_of, with where its field total came from (the report says it)."""
    F, src = field_of(ds)
    return {**world_of(ds, F), "field_from": src}


def fit(ds, use_poses=None, sigma_acc=None, sigma_mag=None, mount_tolerance_deg=None, accept_mount_tolerance=False,
        **_):
    """One triad's calibration (the accelerometer's or the magnetometer's).
    Without poses the triad's rotation against the probe's axes is free: an
    accelerometer's tilt about x and y is the inclination's, so its report
    adds the mounting tolerance (mount_tolerance_deg, 1 sigma per axis,
    default field.DEFAULT_MOUNT_TOLERANCE_DEG) to the inclination it
    predicts, as the joint fit does to the azimuth; accept_mount_tolerance
    records that the user accepts it (the verdict then judges the fit)."""
    kind = "acc" if ds.has_acc else "mag"
    raw = ds.acc if kind == "acc" else ds.mag
    w = world(ds)
    sigma = assumed_noise(ds, sigma_acc, sigma_mag)["acc_g" if kind == "acc" else "mag_nT"]
    poses = _poses(ds, kind) if use_poses is None else bool(use_poses)
    if poses and not _poses(ds, kind):
        raise DataError("the dataset lacks the pose columns (inc_deg, tf_deg" + (", azi_deg" if kind == "mag" else "")
                        + ")")
    moving = np.zeros(len(raw), bool)
    if poses:
        t = truth(ds, kind, w)
        M, b, cov, info = triad.fit_poses(raw, t, sigma, min_rows=MIN_ROWS_POSES)
        groups = _pose_groups(ds)
        ng = int(groups.max()) + 1
        info["poses"] = ng
        if ng < len(ds) and 3 * ng > 12:
            # the pose-level covariance: the fit to each pose's mean reading, scaled by the means' own scatter
            keep = info["keep"]
            gm = np.array([raw[keep & (groups == k)].mean(0) if (keep & (groups == k)).any() else np.full(3, np.nan)
                           for k in range(ng)])
            tm = np.array([t[groups == k][0] for k in range(ng)])
            ok = np.all(np.isfinite(gm), axis=1)
            if ok.sum() * 3 > 12:
                Mp, bp, _, _ = triad.fit_poses(gm[ok], tm[ok], sigma, min_rows=5)
                rv, tv = _noise_var(raw, keep, groups, tm, Mp, sigma)
                cov, pi = triad.pose_mean_covariance(gm[ok], tm[ok], Mp, bp, rv[ok], tangential_var=tv[ok])
                info["pose_level"] = pi
                info["covariance_source"] = (
                    f"pose level: the fit to the {int(ok.sum())} poses' mean readings (readings at one pose share "
                    f"its placement error): the readings' own noise, and across gravity a placement error of "
                    f"{pi['placement_deg']:.3g} deg beside it"
                    + (f" ({pi['radial']:.3g}x in the means' scatter)" if pi["radial"] > 1.0 else ""))
        info.setdefault("covariance_source", "row level, scaled by the residual variance")
        info["mode"] = "poses"
    else:
        R = w["gravity_g"] if kind == "acc" else w["field_nT"]
        from inclino import holds

        from . import motion

        what = "the accelerometer" if kind == "acc" else "the magnetometer"
        hs = holds.determining(ds, (kind,))
        moved = None
        if hs is None and kind == "acc":
            # a log read mostly while moving whose holds determine the ellipsoid and whose moving rows carry the
            # hand's acceleration (calib.motion): the holds alone, as for a step-and-hold log
            mh = motion.holds_fit(ds, (kind,), R, sigma)
            if mh is not None:
                hs, moved = mh[:2], mh[2]
        if hs is not None:
            moving = hs[0] < 0
        # the rows of one hold share its orientation's error, whether or not the holds alone are fitted; with no
        # hold, neighbouring rows of a log read while moving share the hand's acceleration (the blocks' covariance)
        hl = hs if hs is not None else holds.correlated(ds, (kind,))
        # a step-and-hold log: the holds are fitted, the rows read while turning between them left out (their
        # acceleration is the motion's, not the sensor's)
        try:
            M, b, cov, info = triad.fit_sphere(raw[~moving], R, sigma, min_rows=MIN_ROWS_SPHERE, what=what,
                                               blocks=hl is None, refits=triad.REFITS, axis_noise=hl is None)
        except (DataError, CalibrationError) as e:
            cause = motion.refusal(ds, e, hs, hl)
            if cause is None:
                raise
            raise type(e)(cause) from e
        keep = np.zeros(len(raw), bool)
        keep[~moving] = info["keep"]
        info["keep"] = keep
        info["covariance_source"] = "ellipsoid fit, scaled by the residual variance"
        if hs is not None:
            info["moving_rows"] = int(moving.sum())
            info["holds"] = hs[1]
        if moved is not None:
            info["moving_log"] = moved
        elif kind == "acc":
            info["motion"] = motion.figures(ds)  # a log read mostly while moving, fitted on every row (or None)
        if info["blocks"] is not None:
            bl = info["blocks"]
            # (what errs alike on neighbouring rows: a magnetometer has no hand's acceleration to carry, but the
            # field's disturbances and its own slow changes as it turns)
            why = "the hand's acceleration" if kind == "acc" else "the field's disturbances as it turns"
            info["covariance_source"] = (f"blocks of {bl['rows']} consecutive rows ({bl['count']}): the residuals "
                                         f"are correlated from row to row (a log read while moving: {why}), so the "
                                         f"rows are not independent; the blocks' covariance is "
                                         f"{bl['var_ratio']:.3g} times the rows'")
        if info["refits"] is not None:
            info["covariance_source"] = (f"{info['refits']['refits']} refits of readings simulated from the fit, "
                                         f"their scatter and mean shift: {info['refits']['var_ratio']:.3g} times the "
                                         f"variance before them (the fit curves in the noise: orientations bunched "
                                         f"to one side)" + ("; the rows counted in blocks before" if info["blocks"]
                                                            else ""))
        if hl is not None:
            # holds that leave a term nearly free: the verdict says which, beside the inclination it predicts
            info["holds_coverage"] = holds.undetermined_text(ds, hl[0], hl[1], kind, what)
        else:
            # ... and rows whose own directions leave one free, fitted every one
            from .ellipsoid import rows_coverage

            info["holds_coverage"] = rows_coverage(raw[info["keep"]], what)
        hold_cov = triad.hold_covariance(raw, hl[0], keep, R, sigma, fit=(M, b)) if hl is not None else None
        if hold_cov is not None and np.trace(hold_cov[0]) > np.trace(cov):
            cov = hold_cov[0]
            found = "found in the readings" + ("" if hs is not None else ", too few or too few directions to fit "
                                                                          "alone: every row is fitted")
            if hs is not None:  # the holds alone fitted: the rows' fit, each hold's rows sharing an error
                counted = (f"the {hold_cov[1]} static holds ({found})" if hold_cov[1] == hold_cov[2] else
                           f"{hold_cov[1]} orientations held: the {hold_cov[2]} static holds {found}, "
                           f"neighbours within {holds.HOLD_MERGE_DEG:g} deg of each other counted as one (a hand "
                           f"that drifts holds one orientation)")
                info["covariance_source"] = (f"hold level: the rows' fit with each of {counted} sharing an error, "
                                             f"its size from how much more their mean residuals scatter than their "
                                             f"rows (the rows of one hold share its orientation's error)")
            else:
                counted = (f"the {hold_cov[1]} static holds' mean readings ({found})" if hold_cov[1] == hold_cov[2]
                           else f"the mean readings of {hold_cov[1]} orientations held: the {hold_cov[2]} static "
                                f"holds {found}, neighbours within {holds.HOLD_MERGE_DEG:g} deg of each other "
                                f"counted as one (a hand that drifts holds one orientation)")
                info["covariance_source"] = (f"hold level: the fit to {counted}, scaled by their scatter (the rows "
                                             f"of one hold share its orientation's error)")
        info["unobservable"] = ("the triad's rotation: without poses |g| (|b|) alone leaves it free; the body frame "
                                "is the sensor's own axes (M symmetric)")
        if kind == "acc":
            from .field import DEFAULT_MOUNT_TOLERANCE_DEG

            info["mount_tolerance_deg"] = DEFAULT_MOUNT_TOLERANCE_DEG if mount_tolerance_deg is None \
                else float(mount_tolerance_deg)
            info["accept_mount_tolerance"] = bool(accept_mount_tolerance)
    eye = np.eye(3).tolist()
    zero = [0.0, 0.0, 0.0]
    if kind == "acc":
        cal = Calibration(acc_m=M.tolist(), acc_b=b.tolist(), mag_m=eye, mag_b=zero, method="joint",
                          probe_serial=str(ds.meta.get("probe_serial", "")), triads="acc")
    else:
        cal = Calibration(acc_m=eye, acc_b=zero, mag_m=M.tolist(), mag_b=b.tolist(), method="joint",
                          probe_serial=str(ds.meta.get("probe_serial", "")), triads="mag")
    refuse_out_of_range(ds, cal)
    cal.check()
    # rows read while moving between holds: left out, neither outliers nor a break in a segment of misfit
    fitted = np.flatnonzero(~moving)
    segs, scattered = triad.segments(~info["keep"][fitted], ds, rows=fitted)
    info.update({"kind": kind, "sigma": sigma, "covariance12": cov, "segments": segs, "outliers": scattered,
                 "rows_used": np.flatnonzero(info["keep"]), "world": w})
    return cal, info
