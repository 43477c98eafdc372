"""Benchmarks of the fixed-point core (`inclino bench accuracy|speed --json`).

A benchmark measures; the targets are reported next to the figures and the
verdict is a field of the result, not an assertion.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.engines import firmware as core, attitude as engines, golden, reference
from inclino.formats.calfile import Calibration
from inclino.model.typical_probe import _raw_for, typical_calibration  # noqa: F401
from inclino.formats.jsonout import dumps

TARGETS = {
    "inc_max_deg": 0.01,
    "azi_max_deg": 0.01,  # I >= 5 deg
    "azi_max_low_inc_deg": 0.02,  # 1 <= I < 5 deg
    "inc_rms_deg": 0.003,
    "azi_rms_deg": 0.003,
}


def sphere_poses(inc_step=1.0, azi_step=5.0, tf_step=30.0):
    inc = np.arange(0.0, 180.0 + 1e-9, inc_step)
    azi = np.arange(0.0, 360.0, azi_step)
    tf = np.arange(0.0, 360.0, tf_step) + 7.0  # off the axes
    I, A, T = np.meshgrid(inc, azi, tf, indexing="ij")
    return I.ravel(), A.ravel(), T.ravel()


def _err_stats(a, b, inc_true):
    e = {}
    d_inc = np.abs(a["inc_deg"] - b["inc_deg"])
    d_azi = np.abs(reference.angle_diff(a["azi_deg"], b["azi_deg"]))
    d_tf = np.abs(reference.angle_diff(a["tf_deg"], b["tf_deg"]))
    defined = (inc_true >= 1.0) & (inc_true <= 179.0)
    hi = (inc_true >= 5.0) & (inc_true <= 175.0)
    low = defined & ~hi
    e["inc_max_deg"] = float(d_inc.max())
    e["inc_rms_deg"] = float(np.sqrt(np.mean(d_inc**2)))
    e["azi_max_deg"] = float(d_azi[hi].max())
    e["azi_max_low_inc_deg"] = float(d_azi[low].max())
    e["azi_rms_deg"] = float(np.sqrt(np.mean(d_azi[defined] ** 2)))
    e["tf_max_deg"] = float(d_tf[defined].max())
    e["tf_rms_deg"] = float(np.sqrt(np.mean(d_tf[defined] ** 2)))
    e["dip_max_deg"] = float(np.abs(a["dip_deg"] - b["dip_deg"]).max())
    e["gt_max_rel"] = float(np.abs(a["gt_g"] / b["gt_g"] - 1).max())
    e["bt_max_rel"] = float(np.abs(a["bt_nT"] / b["bt_nT"] - 1).max())
    return e


@dataclass
class AccuracyResult:
    poses: int
    field_nT: float
    dip_deg: float
    figures: dict = field(default_factory=dict)
    sources: dict = field(default_factory=dict)
    targets: dict = field(default_factory=dict)
    passed: bool = False
    averaging: dict = field(default_factory=dict)  # bench_averaging.AveragingResult.to_dict()
    temperature: dict = field(default_factory=dict)  # benchmarks.temperature.temperature_loss()

    def to_json(self) -> str:
        d = {**self.figures, "poses": self.poses, "field_nT": self.field_nT, "dip_deg": self.dip_deg,
             "sources": self.sources, "targets": self.targets, "averaging": self.averaging,
             "temperature": self.temperature, "pass": self.passed}
        return dumps(d)


def accuracy(field_nT=50000.0, dip_deg=60.0, cal: Calibration | None = None,
             inc_step=1.0, azi_step=5.0, tf_step=30.0) -> AccuracyResult:
    """Fixed point (the C) against float64 on the same integer inputs.

    Headline figures: C with the quantised coefficients vs float with the
    file's float coefficients, both on the same sensor counts.  Sources:
      input_quantisation: float on counts vs float on the unquantised readings;
      coefficient_quantisation: float with dequantised fixed coefficients vs
        float coefficients, same counts;
      algorithm: C vs float with the dequantised fixed coefficients, same counts.
    Azimuth and toolface are scored for 1 <= I <= 179 deg; the azimuth max
    target for I >= 5 deg, a looser one for 1 <= I < 5 deg."""
    cal = cal or typical_calibration()
    I, A, T = sphere_poses(inc_step, azi_step, tf_step)
    g_true, b_true = reference.body_vectors(I, A, T, field_nT, dip_deg)
    ga, bm = _raw_for(cal, g_true, b_true)
    acc_q = reference.quantise_acc(ga) * reference.ACC_LSB_G
    mag_q = reference.quantise_mag(bm) * reference.MAG_LSB_NT
    cal_q = Calibration.from_fixed(cal.to_fixed())

    fixed = engines.run(acc_q, mag_q, cal, "firmware")
    ref_same = engines.run(acc_q, mag_q, cal, "reference")
    ref_unq = engines.run(ga, bm, cal, "reference")
    ref_cq = engines.run(acc_q, mag_q, cal_q, "reference")

    figs = _err_stats(fixed, ref_same, I)
    sources = {
        "input_quantisation": _err_stats(ref_same, ref_unq, I),
        "coefficient_quantisation": _err_stats(ref_cq, ref_same, I),
        "algorithm": _err_stats(fixed, ref_cq, I),
    }
    from inclino.benchmarks.averaging import averaging_loss

    avg = averaging_loss(field_nT=field_nT, dip_deg=dip_deg)
    from inclino.benchmarks.temperature import temperature_loss

    temp = temperature_loss(field_nT=field_nT, dip_deg=dip_deg, cal=cal)
    passed = all(figs[k] <= v for k, v in TARGETS.items()) and avg.passed and temp["pass"]
    return AccuracyResult(len(I), field_nT, dip_deg, figs, sources, dict(TARGETS), passed, avg.to_dict(), temp)


@dataclass
class SpeedResult:
    batched_vectors_per_s: float
    golden_vectors_per_s: float
    per_call_vectors_per_s: float
    per_call_to_batched_cost_ratio: float
    vectors: int

    def to_json(self) -> str:
        return dumps(asdict(self))


def speed(vectors: int = 1_000_000, per_call_vectors: int = 20_000, seed: int = 3) -> SpeedResult:
    from inclino.engines.bitexact import random_vectors

    rng = np.random.default_rng(seed)
    acc, mag = random_vectors(rng, vectors)
    fc = typical_calibration().to_fixed()

    def best(fn, reps=3):
        ts = []
        for _ in range(reps):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return min(ts)

    t_b = best(lambda: core.survey(acc, mag, fc))
    ng = min(vectors, 200_000)
    arrs = fc.arrays()
    t_g = best(lambda: golden.survey_compute(acc[:ng], mag[:ng], *arrs), reps=1)
    npc = min(per_call_vectors, vectors)
    al, ml = acc[:npc].tolist(), mag[:npc].tolist()

    def per_call():
        for a, m in zip(al, ml):
            core.survey_one(a, m, fc)

    t_p = best(per_call, reps=1)
    b = vectors / t_b
    p = npc / t_p
    return SpeedResult(b, ng / t_g, p, b / p, vectors)
