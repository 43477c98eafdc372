"""`inclino demo`: a table of turntable poses, read by ideal sensors, run
through the firmware's C core and through the float64 reference side by side."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inclino import engines, golden, reference

# (inclination, azimuth, toolface) in degrees; Li 2021 Table 1 position 1 is
# (90, 0, 180): X down, Y west, Z north.
POSES = [
    (0.0, 0.0, 0.0),
    (0.3, 120.0, 40.0),
    (2.0, 45.0, 30.0),
    (10.0, 90.0, 120.0),
    (30.0, 135.0, 200.0),
    (45.0, 200.0, 300.0),
    (60.0, 270.0, 45.0),
    (90.0, 0.0, 180.0),
    (90.0, 315.0, 90.0),
    (120.0, 30.0, 10.0),
    (178.0, 100.0, 250.0),
]


@dataclass
class DemoResult:
    poses: np.ndarray
    fixed: dict
    ref: dict
    field_nT: float
    dip_deg: float


def run(field_nT: float = 50000.0, dip_deg: float = 60.0) -> DemoResult:
    p = np.array(POSES)
    g, b = reference.body_vectors(p[:, 0], p[:, 1], p[:, 2], field_nT, dip_deg)
    acc = reference.quantise_acc(g) * reference.ACC_LSB_G
    mag = reference.quantise_mag(b) * reference.MAG_LSB_NT
    return DemoResult(p, engines.run(acc, mag, None, "firmware"), engines.run(acc, mag, None, "reference"),
                      field_nT, dip_deg)


def render(r: DemoResult) -> str:
    head = (f"Ideal probe on a turntable, field {r.field_nT:g} nT, dip {r.dip_deg:g} deg; "
            "C = the firmware's fixed-point core (via cffi), F = float64 reference on the same counts\n")
    cols = (f"{'set I':>6} {'set A':>6} {'set T':>6} | {'C inc':>9} {'F inc':>9} | {'C azi':>9} {'F azi':>9} |"
            f" {'C tf':>9} {'F tf':>9} | {'C Gt':>7} {'C Bt':>8} {'C dip':>7} | flags")
    lines = [head, cols, "-" * len(cols)]
    for i, (I, A, T) in enumerate(r.poses):
        f, e = r.fixed, r.ref
        fl = int(f["flags"][i])
        lines.append(
            f"{I:6.1f} {A:6.1f} {T:6.1f} | {f['inc_deg'][i]:9.4f} {e['inc_deg'][i]:9.4f} |"
            f" {f['azi_deg'][i]:9.4f} {e['azi_deg'][i]:9.4f} | {f['tf_deg'][i]:9.4f} {e['tf_deg'][i]:9.4f} |"
            f" {f['gt_g'][i]:7.5f} {f['bt_nT'][i]:8.1f} {f['dip_deg'][i]:7.3f} | "
            + (",".join(golden.flag_names(fl)) or "-"))
    lines.append("")
    lines.append("Azimuth and toolface are undefined where the near-vertical flag is set (I < 0.5 deg).")
    return "\n".join(lines)
