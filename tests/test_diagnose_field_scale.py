"""The field total diagnose scales |b| by when the run has no field_nT:
the radius of the sphere the raw readings lie on (as calibrate takes it,
calib.common.world_of), which a hard-iron offset does not move, not the
median raw |b|, which holds the offset too (a VMU931 log: a median of
176 871 nT about a sphere of 36 549 nT printed every |b| residual 4.8
times too large)."""
import dataclasses

import numpy as np
import pytest

from inclino.benchmarks import diagnose_real as dr
from inclino.diagnose import plans
from inclino.diagnose.analysis import diagnose

MAG = ("mx_nT", "my_nT", "mz_nT")


def _offset(ds, rng, times):
    """The same readings with a hard-iron offset `times` the median |b| in a
    random direction added to every row."""
    u = rng.normal(size=3)
    off = times * float(np.median(np.linalg.norm(ds.mag, axis=1))) * u / np.linalg.norm(u)
    cols = dict(ds.columns)
    for c, o in zip(MAG, off):
        cols[c] = np.asarray(cols[c], float) + o
    return dataclasses.replace(ds, columns=cols)


def test_pose_free_residuals_do_not_grow_with_a_hard_iron_offset(rng):
    """SAP6's 24 shots (no field_nT): the pose-free model holds an offset,
    so the same readings shifted by three times the field fit the same
    sphere; |b|'s residual RMS and the field total it is scaled to stay."""
    data = dict(dr.corpus())
    if not data:
        pytest.skip("the corpus is not in this checkout")
    ds = data["sap6/BB"]
    assert ds.meta.get("field_nT") is None
    r0, r1 = diagnose(ds), diagnose(_offset(ds, rng, 3.0))
    assert r1.baseline["field_nT"] == pytest.approx(r0.baseline["field_nT"], rel=1e-6)
    assert r1.baseline["rms"]["|b|"] == pytest.approx(r0.baseline["rms"]["|b|"], rel=1e-4)


def test_with_poses_the_field_total_is_the_sphere_not_the_offset(rng):
    """A simulated turntable run (field 50 000 nT) with its header's field
    taken out and an offset of three times the field added: the field
    total the pose-based diagnosis works in is still about 50 000 nT."""
    ds = plans.generate(plans.PROBE, plans.li_grid_plan(seed=3), 5)
    F = ds.meta["field_nT"]
    meta = {k: v for k, v in ds.meta.items() if k != "field_nT"}
    r = diagnose(dataclasses.replace(_offset(ds, rng, 3.0), meta=meta))
    assert abs(r.baseline["field_nT"] / F - 1.0) < 0.01
