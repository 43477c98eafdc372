"""Tests that hide an effect: emulated bench datasets (inclino_emu, through
inclino.diagnose.plans) with one library effect at a random sensor, axis and
sign, its signature 9-12 noise sigmas once the baseline has absorbed what it
can (bench.Z_RANGE; peak change of a reading about 1-7 sigma of the sensor
noise) -- 2.5-3.5 times the detection limit (~3.6 sigma at alpha = 0.01
over two dozen candidates; 50 % points at z 2.8-4.6).  Nearer the limit
the diagnosis benchmark measures the rates (`python -m
inclino.cli.bench_diagnose --near-limit`): at z = 6 the hardest effects
are missed 0.3-1.7 % of the time, which 21 draws per run would turn into a
failing suite every few runs; at z = 9 none of 1 200, nor of 300 field
drifts (docs/diagnose.md).
The diagnosis must name exactly that effect and estimate it within its
stated uncertainty; on null datasets it must name nothing.  Sensors,
axes, signs, sizes and noise are drawn afresh at every run (SEED0 from the
OS; the seed is in every failure message); `bench diagnose` holds the
rates (docs/diagnose.md).

A rig field (12-15 columns, sized by its RMS in nT) is checked on what the
plan allows, not on z: two turntable axes' fields overlap 0.85-0.98 on
these plans, so the other axis' field may be kept provided the report says
the run cannot tell them apart (3 % of draws at z 9-12); and its size's
standard error is set by the noise along the field (the turntable's
readout error across the meridian, ~4x the fluxgate's), so it is checked
against the truth's (plans.rig_rms_stderr) instead of against z: at z =
9-12 it is 1/8-1/2 of the size, not 1/9-1/12 (300 draws, refits of one
draw under fresh noise scatter as the stated error says: 0.45 against
0.49 nT over 40)."""
import json

import numpy as np
import pytest
from conftest import test_seed

from inclino.engines import reference as ref
from inclino.benchmarks import diagnose as bench
from inclino.diagnose import core, plans
from inclino.diagnose.analysis import diagnose

# drawn at test time: every run hides other sensors, axes, signs and sizes (the seed is in the failure message)
RNG_SEED = SEED0 = test_seed() % 1_000_000_000  # INCLINO_TEST_SEED replays a run (conftest)
CASES = [(name, k) for name in core.EFFECT_NAMES for k in range(3)]


@pytest.mark.parametrize("effect,k", CASES)
def test_hidden_effect_is_named_and_estimated_within_its_stderr(effect, k):
    seed = SEED0 + 10 * core.EFFECT_NAMES.index(effect) + k
    kinds = bench.EFFECT_PLANS[effect]
    c = bench.run_case(effect, kinds[seed % len(kinds)], seed)
    h = c["hidden"]
    h = dict(h, seed=seed)
    assert bench.Z_RANGE[0] <= h["z"] <= bench.Z_RANGE[1] and h["peak_over_noise"] < 8.0  # not a gross error
    named = [(f["name"], f["sensor"], f["axis"]) for f in c["found"]]
    # drawn afresh every run, so the checks are at rates the bench measures near 100 %: the hidden effect is
    # named on its sensor and axis (another name beside it, 0-7 % per dataset in the bench, is not a failure
    # here; the nulls below hold the false-alarm side)
    if effect == "rig-field" and (h["name"], h["sensor"], h["axis"]) not in named:
        # fields of two turntable axes overlap 0.85-0.98 on these plans (12-15 columns each): at z 9-12
        # the other axis' field is kept in ~3 % of draws; the run cannot tell them apart, and the
        # diagnosis must say so (the named field reported as confounded with the hidden axis')
        assert c["named_with_confound"], f"hid {h}, named {named}, confounded {c['confounded']}"
        return
    assert (h["name"], h["sensor"], h["axis"]) in named, f"hid {h}, named {named}"
    f = next(f for f in c["found"] if (f["name"], f["sensor"], f["axis"]) == (h["name"], h["sensor"], h["axis"]))
    assert abs(f["estimate"] - h["value"]) <= 4.0 * f["stderr"], (f, h)
    if effect == "rig-field":
        # its size is an RMS in nT, which z (the whitened norm, what detection needs) does not bound: the
        # turntable's azimuth readout error moves the field ~20 nT across the magnetic meridian against
        # the fluxgate's 5 nT, so a field lying there is known to 1/4-1/2 of its size at z = 9-12.  The
        # stated stderr must match what the plan allows (plans.rig_rms_stderr, from the truth): over 300
        # draws 0.66-1.43 times it, and 2.25 once, where a second effect named beside it shared its variance
        assert 0.5 * h["stderr_truth"] < f["stderr"] < 3.0 * h["stderr_truth"], (f, h)
        assert f["stderr"] < abs(h["value"]) / 1.5, (f, h)
    else:
        assert f["stderr"] < abs(h["value"]) / 3.0  # the uncertainty is informative, not a blanket


@pytest.mark.heavy
def test_null_datasets_name_nothing():
    """Twelve nulls drawn afresh (six static, six continuous). The bench
    measures a false-alarm rate near 1.5 % (3 of 216; 1 of 40 continuous and
    1 of 60 static in a separate draw), so at most three may name an effect
    or show unexplained structure: four or more has probability 7e-5 at a 2 %
    rate (the suite must not fail by chance); this test catches a gross
    regression (a 25 % rate fails a third of runs), `bench diagnose` holds the
    rate itself over 200+ nulls."""
    bad = []
    for k, kind in enumerate(("static", "continuous") * 6):
        seed = SEED0 + 900 + k
        c = bench.run_case(None, kind, seed)
        if c["found"] or c["unexplained"]:
            bad.append((seed, kind, c["found"], c["unexplained"]))
    assert len(bad) <= 3, bad


def test_signature_below_the_detection_limit_is_not_named():
    """2 sigma is below the Bonferroni threshold: the control does not let
    it through (while 9-12 sigma is found above)."""
    c = bench.run_case("temperature-bias", "static", 950, z=2.0)
    assert c["found"] == []


def test_two_effects_at_once_are_both_named():
    p = plans.hide(plans.PROBE, "temperature-bias", "acc", "y", 6e-6)
    p = plans.hide(p, "field-drift", "field", "total", 5e-4)
    r = diagnose(plans.generate(p, plans.oven_plan(seed=3), 3))
    got = {(e.name, e.sensor, e.axis): e for e in r.effects}
    assert set(got) == {("temperature-bias", "acc", "y"), ("field-drift", "field", "total")}
    for key, truth in ((("temperature-bias", "acc", "y"), 6e-6), (("field-drift", "field", "total"), 5e-4)):
        assert abs(got[key].estimate - truth) <= 3 * got[key].stderr
    assert not r.unexplained


def _backlash_dataset(seed, lag_deg):
    """The toolface lags lag_deg behind each move (backlash): not a library
    effect, so it must come out as unexplained structure."""
    plan = plans.oven_plan(seed=seed)
    d = np.concatenate([[0.0], ref.angle_diff(plan["tf"][1:], plan["tf"][:-1])])
    last, cur = np.zeros(len(d)), 0.0
    for i, x in enumerate(d):
        cur = np.sign(x) if abs(x) > 0.5 else cur
        last[i] = cur
    true = dict(plan, tf=np.mod(plan["tf"] - lag_deg * last, 360.0))
    ds = plans.generate(plans.PROBE, true, seed)
    ds.columns["tf_deg"] = plan["tf"].copy()
    return ds


def test_structure_no_library_effect_explains_is_unexplained():
    r = diagnose(_backlash_dataset(7, 0.05))
    assert r.unexplained
    assert any(s["test"] == "move" for s in r.structure["significant"])
    # the same plan without the backlash is clean
    r0 = diagnose(_backlash_dataset(7, 0.0))
    assert not r0.unexplained and r0.effects == []


def test_gain_and_json_shape():
    p = plans.hide(plans.PROBE, "scale-nonlinearity", "acc", "z", 5e-4)
    r = diagnose(plans.generate(p, plans.oven_plan(seed=4), 4))
    d = json.loads(r.to_json())
    assert list(d) == ["baseline", "effects", "contradicted", "confounded", "unexplained", "checks", "calibrate",
                       "motion", "pairing", "conclusion"]
    assert isinstance(d["unexplained"], bool)
    (e,) = d["effects"]
    assert list(e) == ["name", "sensor", "axis", "estimate", "stderr", "units", "gain", "detail"]
    assert list(e["gain"]) == ["rms_before", "rms_after", "cv_rms_before", "cv_rms_after", "azi_rms_before_deg",
                               "azi_rms_after_deg", "inc_rms_before_deg", "inc_rms_after_deg"]
    assert (e["name"], e["sensor"], e["axis"], e["units"]) == ("scale-nonlinearity", "acc", "z", "1/g")
    g = e["gain"]
    assert g["rms_after"] < g["rms_before"] and g["cv_rms_after"] < g["cv_rms_before"]
    assert g["inc_rms_after_deg"] < g["inc_rms_before_deg"]
    b = d["baseline"]
    assert b["selection"]["alpha"] == 0.01 and b["rows"] == 288
    assert abs(b["noise"]["pose_deg"]["inc"] - plans.TURNTABLE_SIGMA_DEG) < 0.01  # noise from the data
    assert abs(b["noise"]["acc_g"][0] - plans.ACC_SIGMA_G) < 4e-5


def test_turntable_geometry_model_of_the_emulator():
    """world.TurntableGeometry (added for the Li 2021 checks): the tilted
    azimuth axis and the skewed inclination axis move the tool axis as
    documented, and no geometry is the plain pose matrix."""
    from inclino.model.world import Turntable, TurntableGeometry, World

    I = np.array([2.0, 20, 45, 90, 90, 60])
    A = np.array([0.0, 90, 30, 0, 200, 300])
    T = np.array([0.0, 30, 60, 90, 10, 200])
    np.testing.assert_allclose(TurntableGeometry().pose_matrix(I, A, T), ref.pose_matrix(I, A, T), atol=1e-15)
    e = 0.1

    def attitude_error(**kw):
        g, b = World(turntable=Turntable(geometry=TurntableGeometry(**kw))).truth(I, A, T)
        a = ref.attitude(g, b)
        return a["inc"] - I, ref.angle_diff(a["azi"], A)

    di, da = attitude_error(tilt_north_deg=e)
    np.testing.assert_allclose(di, e * np.cos(np.radians(A)), atol=3e-3)
    np.testing.assert_allclose(da[1:], -e * np.sin(np.radians(A[1:])) / np.tan(np.radians(I[1:])), atol=3e-3)
    di, da = attitude_error(tilt_east_deg=e)
    np.testing.assert_allclose(di, e * np.sin(np.radians(A)), atol=3e-3)
    di, da = attitude_error(skew_deg=e)
    np.testing.assert_allclose(di, 0.0, atol=1e-3)
    np.testing.assert_allclose(da, e * np.tan(np.radians(I / 2)), atol=1e-3)


def test_declination_drift_acts_as_an_azimuth_error():
    """A declination drift turns the field about the vertical: row by row the
    fluxgate reads what an azimuth error of -delta(t) gives, gravity nothing,
    so its column is the pose Jacobian's azimuth column times time (about the
    run's mean).  Its gain is therefore taken net of the inclination and
    toolface readout errors only: net of all three (the sensor part) a few
    per cent of it is left on the oven plan (5 %), net of those two most (91 %)."""
    from inclino.diagnose.analysis import pose_axes_acted_as

    d, _, _, bl, _ = plans.true_baseline(plans.PROBE, plans.oven_plan(seed=1))
    cand = core.Candidate("field-drift", "field", "declination", "deg/s")
    reg = core.regressor(d, bl, cand)
    ja = bl.Jpose[:, :, 1] * core._tau(d)[:, None]
    assert np.abs(reg[:, :3]).max() == 0.0
    corr = np.sum(reg * ja) / np.sqrt(np.sum(reg ** 2) * np.sum(ja ** 2))
    assert corr < -0.9999  # d/d(declination) = -d/d(azimuth)
    kept = plans.true_noise().sensor_part(reg, bl.Jpose)
    assert np.sqrt(np.mean(kept ** 2) / np.mean(reg ** 2)) < 0.1
    kept = plans.true_noise().sensor_part(reg, bl.Jpose, axes=(0, 2))
    assert np.sqrt(np.mean(kept ** 2) / np.mean(reg ** 2)) > 0.8  # 0.91: the accelerometer pins inc and tf
    assert pose_axes_acted_as(cand) == (1,)
    assert pose_axes_acted_as(core.Candidate("field-drift", "field", "dip", "deg/s")) == ()
    assert pose_axes_acted_as(core.Candidate("field-drift", "field", "total", "nT/s")) == ()


def test_declination_drift_near_the_limit_is_named():
    """A draw the diagnosis missed while it measured the drift's gain on the
    sensor part: a declination drift on the oven plan at z = 10.2 (seed
    615983673); its p-value was 0 and the whitened held-out residual fell,
    but the own-channel check saw 5 % of the signal and refused it."""
    c = bench.run_case("field-drift", "static", 615983673)
    h = c["hidden"]
    assert (h["name"], h["axis"]) == ("field-drift", "declination") and bench.Z_RANGE[0] <= h["z"] <= bench.Z_RANGE[1]
    assert c["detected"], c
    f = next(f for f in c["found"] if (f["name"], f["axis"]) == ("field-drift", "declination"))
    assert abs(f["estimate"] - h["value"]) <= 4.0 * f["stderr"], (f, h)


@pytest.mark.parametrize("effect,kind,seed", [
    ("turntable-inclination-axis-skew", "continuous", 525331931),
    ("turntable-inclination-axis-skew", "continuous", 1059),
    ("turntable-azimuth-offset", "static", 935660852),
])
def test_turntable_effect_near_the_limit_is_named(effect, kind, seed):
    """Draws the diagnosis missed while it took a turntable effect's own
    held-out residual in a metric other than the fit's.  On one triad in
    its units: an inclination-axis skew on the continuous plan at z = 10.8
    and 9.6, p = 1e-26 and 5e-15, the whitened held-out residual falling,
    but the fluxgate's whole residual (34 nT of it the turntable's readout
    error) rising by 0.02-0.06 nT.  On both triads, each channel divided by
    its own noise SD: an azimuth offset of -0.036 deg on the static plan at
    z = 9.6, p = 1e-16, azimuth RMS 0.059 -> 0.055 deg, that RMS rising
    0.9943 -> 0.9945 (the readout error's correlated part counted as
    independent).  The gain is now both triads whitened by each row's
    covariance, the metric of the fit."""
    c = bench.run_case(effect, kind, seed)
    h = c["hidden"]
    assert h["name"] == effect and bench.Z_RANGE[0] <= h["z"] <= bench.Z_RANGE[1]
    assert c["detected"], c
    f = next(f for f in c["found"] if f["name"] == effect)
    assert abs(f["estimate"] - h["value"]) <= 4.0 * f["stderr"], (f, h)


def test_turntable_gain_is_on_both_triads_whitened():
    """The gain a turntable effect is named on: both triads, whitened by
    each row's noise covariance (about 1 when the model fits)."""
    from inclino.diagnose import analysis
    from inclino.diagnose.analysis import diagnose as diag

    plan = bench._plan("static", 7)
    cand = next(c for c in core.all_candidates() if c.name == "turntable-azimuth-offset")
    zu = plans.signature_z(plans.PROBE, plan, cand)
    ds = plans.generate(plans.hide(plans.PROBE, cand.name, cand.sensor, cand.axis, 30.0 / zu), plan, 7)
    r = diag(ds)
    (e,) = [e for e in r.effects if e.name == "turntable-azimuth-offset"]
    assert e.rms_units == analysis.TURNTABLE_GAIN_UNITS
    assert 0.8 < e.gain.cv_rms_after < e.gain.cv_rms_before and e.gain.cv_rms_after < 1.2
