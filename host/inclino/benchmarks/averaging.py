"""What the firmware keeps of an averaged acquisition (`inclino bench accuracy`,
key `averaging`).

For each inclination I and averaging n, `trials` surveys of the typical probe
(bench.typical_calibration, random azimuth and toolface, 50 000 nT, dip 60 deg)
are simulated sample by sample as the probe acquires them: each sample is the
uncalibrated reading plus Gaussian noise (sigma_acc g, sigma_mag nT), rounded
to whole counts by the sensor; the integer sums are averaged as acquire.c
does.  Per cell:

* `noise_sigma_deg`: the noise-limited azimuth sigma, RMS of float64 on the
  noisy mean (unquantised) minus float64 on the noise-free reading;
* `loss_deg`: RMS of the firmware (acq_avg_q6 means, fixed-point correction
  and attitude) minus float64 on the exact mean of the same quantised samples
  (sum / n in double): what the firmware's representation and arithmetic
  lose, the figure the target applies to (loss <= 0.1 x noise sigma);
* `loss_whole_counts_deg`: the same with the means rounded to whole counts
  (the former acquisition, acq_avg), for comparison;
* `sensor_quantisation_deg`: float64 on the quantised samples' mean minus
  float64 on the unquantised mean: the sensors' own 1-count resolution, which
  no firmware representation can recover (it shrinks with n only as far as the
  noise dithers the counts).
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.engines import firmware as core, attitude as engines, golden, reference
from inclino.formats.jsonout import dumps

TARGET_RATIO = 0.1


@dataclass
class AveragingCell:
    inc_deg: float
    n_avg: int
    noise_sigma_deg: float
    loss_deg: float
    loss_whole_counts_deg: float
    sensor_quantisation_deg: float
    ratio: float
    ratio_whole_counts: float


@dataclass
class AveragingResult:
    sigma_acc_g: float
    sigma_mag_nT: float
    trials: int
    cells: list = field(default_factory=list)
    target_ratio: float = TARGET_RATIO
    passed: bool = False

    def to_dict(self) -> dict:
        return asdict(self)

    def to_json(self) -> str:
        return dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str) -> "AveragingResult":
        d = json.loads(text)
        d["cells"] = [AveragingCell(**c) for c in d["cells"]]
        return cls(**d)

    def lines(self) -> list[str]:
        out = [f"averaged readings (noise {self.sigma_acc_g:g} g, {self.sigma_mag_nT:g} nT; {self.trials} surveys "
               f"per cell): azimuth loss firmware vs float64 on the same samples, target <= "
               f"{self.target_ratio:g} x noise sigma"]
        for c in self.cells:
            out.append(f"  I {c.inc_deg:>4g} deg  n {c.n_avg:>2d}: noise sigma {c.noise_sigma_deg:.4f}  loss "
                       f"{c.loss_deg:.5f} ({c.ratio:.3f} x)  whole-count means {c.loss_whole_counts_deg:.5f} "
                       f"({c.ratio_whole_counts:.3f} x)  sensor counts {c.sensor_quantisation_deg:.4f}")
        return out


def _rms_diff(a, b) -> float:
    return float(np.sqrt(np.mean(reference.angle_diff(a, b) ** 2)))


def averaging_loss(incs=(2.0, 5.0, 10.0), navgs=(1, 16, 64), trials: int = 400, sigma_acc_g: float = 1.5e-4,
                   sigma_mag_nT: float = 1.0, seed: int = 5, field_nT: float = 50000.0,
                   dip_deg: float = 60.0) -> AveragingResult:
    from inclino.model import typical_probe as bench

    cal = bench.typical_calibration()
    fc = cal.to_fixed()
    rng = np.random.default_rng(seed)
    res = AveragingResult(sigma_acc_g, sigma_mag_nT, trials)
    for inc in incs:
        for n in navgs:
            I = np.full(trials, float(inc))
            A = rng.uniform(0.0, 360.0, trials)
            T = rng.uniform(0.0, 360.0, trials)
            g, b = reference.body_vectors(I, A, T, field_nT, dip_deg)
            ga, bm = bench._raw_for(cal, g, b)
            acc_s = ga[:, None, :] / reference.ACC_LSB_G + rng.normal(0, sigma_acc_g / reference.ACC_LSB_G,
                                                                       (trials, n, 3))
            mag_s = bm[:, None, :] / reference.MAG_LSB_NT + rng.normal(0, sigma_mag_nT / reference.MAG_LSB_NT,
                                                                        (trials, n, 3))
            acc_sum = np.round(acc_s).astype(np.int64).sum(axis=1)
            mag_sum = np.round(mag_s).astype(np.int64).sum(axis=1)
            fw = core.survey(golden.acq_avg_q6(acc_sum, n), golden.acq_avg_q6(mag_sum, n), fc)
            fw_azi = fw["azi"] / 65536.0
            whole_a = np.floor_divide(2 * acc_sum + n, 2 * n) * golden.IN_ONE  # acq_avg, then x 64
            whole_m = np.floor_divide(2 * mag_sum + n, 2 * n) * golden.IN_ONE
            fw0_azi = core.survey(whole_a, whole_m, fc)["azi"] / 65536.0
            ref_q = engines.run(acc_sum / n * reference.ACC_LSB_G, mag_sum / n * reference.MAG_LSB_NT, cal,
                                "reference")["azi_deg"]
            ref_u = engines.run(acc_s.mean(axis=1) * reference.ACC_LSB_G, mag_s.mean(axis=1) * reference.MAG_LSB_NT,
                                cal, "reference")["azi_deg"]
            ref_0 = engines.run(ga, bm, cal, "reference")["azi_deg"]
            sig = _rms_diff(ref_u, ref_0)
            loss = _rms_diff(fw_azi, ref_q)
            loss0 = _rms_diff(fw0_azi, ref_q)
            res.cells.append(AveragingCell(float(inc), int(n), sig, loss, loss0, _rms_diff(ref_q, ref_u),
                                           loss / sig, loss0 / sig))
    res.passed = all(c.ratio <= TARGET_RATIO for c in res.cells)
    return res
