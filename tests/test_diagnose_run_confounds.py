"""A drift named on a run whose poses were taken in order is named together
with its confound: time rises with the inclination axis, so the effect's
record sets it beside the rig field of that axis (the candidate driven by
the variable time goes with) and says whether the run tells them apart.

The data come from a small simulator written here on its own (the pose
rotation of docs/conventions.md, a 12-parameter calibration per triad,
white noise, pose errors), not from the emulator: the check is of what the
diagnosis says about a run, whoever generated it."""
import numpy as np

from inclino.diagnose.analysis import diagnose
from inclino.formats.dataset import RawDataset


def _C(I, A, T):
    I, A, T = np.radians(I), np.radians(A), np.radians(T)
    cI, sI, cA, sA, cT, sT = np.cos(I), np.sin(I), np.cos(A), np.sin(A), np.cos(T), np.sin(T)
    return np.array([[cT * cI * cA - sT * sA, cT * cI * sA + sT * cA, -cT * sI],
                     [-sT * cI * cA - cT * sA, -sT * cI * sA + cT * cA, sT * sI],
                     [sI * cA, sI * sA, cI]])


def _run(seed, azis=8, tfs=4, rows=1, order="nested", drift_dip_deg=0.0, drift_total_nT=0.0):
    """A turntable run: inclination outer, azimuth, toolface inner (or a random order);
    the field's dip or total drifting linearly over the run."""
    rng = np.random.default_rng(seed)
    poses = np.array([(i, a, t) for i in (5.0, 30, 60, 90, 120, 150, 175)
                      for a in np.arange(azis) * 360.0 / azis for t in np.arange(tfs) * 360.0 / tfs])
    if order == "random":
        poses = poses[rng.permutation(len(poses))]
    Ma, ba = np.eye(3) + rng.normal(0, 0.003, (3, 3)), rng.normal(0, 0.01, 3)
    Mm, bm = np.eye(3) + rng.normal(0, 0.01, (3, 3)), rng.normal(0, 300, 3)
    out = {k: [] for k in ("t_s", "inc_deg", "azi_deg", "tf_deg", "ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT")}
    n = len(poses)
    for k, (I, A, T) in enumerate(poses):
        frac = k / (n - 1)
        d = np.radians(60.0 + drift_dip_deg * frac)
        bw = (50000.0 + drift_total_nT * frac) * np.array([np.cos(d), 0.0, np.sin(d)])
        for _ in range(rows):
            Ct = _C(*(np.array([I, A, T]) + rng.normal(0, 0.02, 3)))
            a = np.linalg.solve(Ma, Ct @ [0, 0, 1.0]) + ba + rng.normal(0, 3e-4, 3)
            m = np.linalg.solve(Mm, Ct @ bw) + bm + rng.normal(0, 30, 3)
            for key, v in zip(out, (len(out["t_s"]) * 1.0, I, A, T, *a, *m)):
                out[key].append(v)
    return RawDataset({k: np.array(v) for k, v in out.items()}, {"field_nT": 50000.0, "dip_deg": 60.0})


def _entry(d, variable):
    (e,) = d.effects
    return e, {r["variable"]: r for r in e.detail.get("run_confounds", [])}.get(variable)


def test_a_drift_in_pose_order_is_set_beside_the_rig_field_of_the_axis_time_rises_with():
    d = diagnose(_run(7, drift_dip_deg=0.5))
    e, r = _entry(d, "inclination axis angle")
    assert (e.name, e.axis) == ("field-drift", "dip")
    assert r is not None and r["correlation"] > 0.95 and r["rival"] == "rig-field:rig:inc"
    # the azimuth turns at every inclination: a field that moves with the inclination axis is not a change of
    # the Earth's field, and the run tells them apart
    assert r["told_apart"] and r["cv_with_effect"] < r["cv_with_rival_instead"]
    text = d.summary()
    assert "confound: its driver goes with the inclination axis angle here" in text and "told apart" in text


def test_a_drift_the_rig_field_reproduces_is_reported_as_not_told_apart():
    # the azimuth never turns: the inclination axis's frame is the Earth's, and a total-field ramp over the
    # run is a smooth function of the inclination, which the rig field's harmonics take as well
    d = diagnose(_run(7, azis=1, tfs=12, rows=2, drift_total_nT=300.0))
    e, r = _entry(d, "inclination axis angle")
    assert (e.name, e.axis) == ("field-drift", "total")
    assert r is not None and not r["told_apart"]
    assert any(c["effect"] == "field-drift:field:total" and c["with"] == "rig-field:rig:inc" for c in d.confounded)
    assert "randomise the pose order" in r["separate_by"]


def test_a_drift_in_random_pose_order_has_no_pose_confound():
    d = diagnose(_run(7, order="random", drift_dip_deg=0.5))
    e, r = _entry(d, "inclination axis angle")
    assert (e.name, e.axis) == ("field-drift", "dip") and r is None
    assert d.confounded == []
