"""Survey QC (firmware qc_check): G total, B total and dip against a reference
with tolerances; C and golden agree, and the verdicts are the geometry's."""
import numpy as np

from inclino.engines import firmware as core, golden, reference

REF_KEYS = ("gt_ref", "gt_tol", "bt_ref", "bt_tol", "dip_ref", "dip_tol")


def _survey(field, dip, inc=30.0, azi=40.0, tf=50.0, gscale=1.0):
    g, b = reference.body_vectors(np.array([inc]), np.array([azi]), np.array([tf]), field, dip)
    return core.survey(reference.quantise_acc(g * gscale) * 64, reference.quantise_mag(b) * 64)


def _qc(att, ref):
    c = core.qc_check(att, ref)
    assert np.array_equal(c, golden.qc_check(att, *(getattr(ref, k) for k in REF_KEYS)))
    return int(c[0])


REF = core.QcRef(bt_ref=50000 * 256, dip_ref=60 * 65536)  # default tolerances: 2.5 mg, 300 nT, 0.25 deg


def test_pass_inside_the_window():
    assert _qc(_survey(50000.0, 60.0), REF) == 0
    assert _qc(_survey(50250.0, 60.2, gscale=1.002), REF) == 0


def test_each_check_fails_alone():
    assert _qc(_survey(50350.0, 60.0), REF) == golden.QC_F_BT
    assert _qc(_survey(49650.0, 60.0), REF) == golden.QC_F_BT
    assert _qc(_survey(50000.0, 60.3), REF) == golden.QC_F_DIP
    assert _qc(_survey(50000.0, 59.7), REF) == golden.QC_F_DIP
    assert _qc(_survey(50000.0, 60.0, gscale=1.004), REF) == golden.QC_F_GT


def test_tolerance_edge_is_inclusive():
    att = {k: np.array([v]) for k, v in dict(inc=0, azi=0, gtf=0, mtf=0, gt=2**27 + 335544,
                                                bt=50000 * 256 - 76800, dip=60 * 65536 + 16384,
                                                flags=0).items()}
    assert _qc(att, REF) == 0
    att["bt"] = att["bt"] - 1
    assert _qc(att, REF) == golden.QC_F_BT


def test_zero_field_is_undefined_not_pass():
    att = core.survey(np.array([[0, 0, 16384 * 64]]), np.array([[0, 0, 0]]))
    assert _qc(att, REF) & golden.QC_F_UNDEFINED


def test_extreme_reference_saturates_instead_of_wrapping():
    att = {k: np.array([v]) for k, v in dict(inc=0, azi=0, gtf=0, mtf=0, gt=2**31 - 1, bt=-(2**31),
                                                dip=0, flags=0).items()}
    ref = core.QcRef(gt_ref=-(2**31), gt_tol=2**31 - 2, bt_ref=2**31 - 1, bt_tol=2**31 - 2, dip_ref=0, dip_tol=0)
    assert _qc(att, ref) == golden.QC_F_GT | golden.QC_F_BT
