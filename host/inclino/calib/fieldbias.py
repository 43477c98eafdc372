"""What the scale nonlinearity a prior's fit found does to a linear field
calibration (without poses), per grid pose.

Apart from field.py because it runs the fit itself (joint.fit), while the fit
uses field.py's rotation helpers: joint -> field, fieldbias -> joint, no cycle.
"""
from __future__ import annotations

from inclino.formats.dataset import RawDataset

from . import joint
from .predict import _model_readings


def nonlinear_bias(nl: dict, prior, fcal, acc, mag, w: dict, dip: float, grid, sigma_acc: float,
                   sigma_mag: float):
    """What the scale nonlinearity the prior's fit found does to a linear
    field fit: noise-free readings of that nonlinear model at the field
    readings' orientations (as the field calibration sees them) are fitted
    the same way (invariants, with the prior); the result is applied to the
    model's readings at the grid poses.  Returns the per-pose azimuth and
    inclination errors (deg)."""
    F, G = w["field_nT"], w["gravity_g"]
    a = ref_attitude(fcal, acc, mag)
    gv, fv = _ref().body_vectors(a["inc"], a["azi"], a["gtf"], F, dip, 0.0, G)
    ra, rm = _model_readings(nl, gv, fv)
    cols = {"ax_g": ra[:, 0], "ay_g": ra[:, 1], "az_g": ra[:, 2], "mx_nT": rm[:, 0], "my_nT": rm[:, 1],
            "mz_nT": rm[:, 2]}
    syn = RawDataset(cols, {"field_nT": F, "dip_deg": dip, "gravity_g": G})
    csyn, _ = joint.fit(syn, use_poses=False, prior=prior, sigma_acc=sigma_acc, sigma_mag=sigma_mag)
    I, A, T = grid
    gg, fg = _ref().body_vectors(I, A, T, F, dip, 0.0, G)
    ga, gm = _model_readings(nl, gg, fg)
    att = ref_attitude(csyn, ga, gm)
    return _ref().angle_diff(att["azi"], A), att["inc"] - I


def _ref():
    from inclino.engines import reference

    return reference


def ref_attitude(cal, acc, mag):
    r = _ref()
    return r.attitude(r.correct(acc, cal.acc_m, cal.acc_b), r.correct(mag, cal.mag_m, cal.mag_b))
