"""The calibration bench's simulated probe and runs: the typical scenario's
probe, its true coefficients, the union of the papers' poses, an emulated run
with turntable readout error, the noise-free Li grid, the attitude errors a
calibration leaves on it.

Apart from bench.py (the comparison of the methods) because the prediction
check (bench_predict.py) uses these and bench.py uses the prediction check.
"""
from __future__ import annotations

import copy

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration

from inclino.calib import runs
from inclino.model.world import pose_in_range

TURNTABLE_SIGMA_DEG = 0.05
MAG_NOISE_NT = 1.0


def bench_probe(linear: bool = False):
    from inclino.model.scenario import load_scenario
    from inclino.model import effects as fx

    s = load_scenario("typical")
    s.mag.noise = fx.WhiteNoise(MAG_NOISE_NT)
    if linear:
        s.acc.nonlinearity = None
        s.mag.nonlinearity = None
    return s


def truth_calibration(s) -> Calibration:
    A, c = s.acc.linear()
    Am, cm = s.mag.linear()
    return Calibration(acc_m=np.linalg.inv(A).tolist(), acc_b=c.tolist(), mag_m=np.linalg.inv(Am).tolist(),
                       mag_b=cm.tolist(), method="truth")


def truth_nonlinear(s) -> np.ndarray:
    """The probe's truth in joint's nonlinear layout (31 entries: M_a, M_a b_a,
    M_m, M_m b_m, q_a, q_m, dip): the emulator's chain raw = h(A0 v + c0) + beta
    with h(y) = y + k2 y^2 inverts, to first order in k2 (the next term is
    2 k2^2 y^3: 8e-8 g, 3e-4 nT here), to v = M (raw + q raw^2/S - b) with
    D = 1 + 2 k2 beta, M = A0^-1 diag(D), q = -k2 S / D,
    b = (beta + k2 beta^2)/D + c0/D."""
    out, qs = [], []
    for t, S in ((s.acc, s.world.gravity_g), (s.mag, s.world.earth.field_nT)):
        A0, c = t.linear()
        beta = t.bias.b if t.bias is not None else np.zeros(3)
        k2 = t.nonlinearity.k2 if t.nonlinearity is not None else np.zeros(3)
        c0 = c - beta
        D = 1.0 + 2.0 * k2 * beta
        M = np.linalg.inv(A0) @ np.diag(D)
        b = (beta + k2 * beta * beta) / D + c0 / D
        out += [M.ravel(), M @ b]
        qs.append(-k2 * S / D)
    return np.concatenate(out + qs + [[s.world.earth.dip_deg]])


def calibration_poses():
    return runs.union(runs.li2021_twelve(), runs.ren2014(), runs.guo2009(), runs.multi_position(60))


def emulated_run(s, poses, seed, sigma_pose_deg=TURNTABLE_SIGMA_DEG):
    """Readings at the true poses (indicated + readout error), pose columns
    holding the indicated poses."""
    from inclino.model.scenario import generate_raw

    rng = np.random.default_rng([seed, 7])
    I, A, T = (np.asarray(p, float) for p in poses)
    true = pose_in_range(*(p + rng.normal(0, sigma_pose_deg, len(p)) for p in (I, A, T)))
    ds = generate_raw(s, *true, seed=seed)
    ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"] = I.copy(), A.copy(), T.copy()
    return ds


def grid_truth(s, temp_c=None):
    """(Li grid poses, noise-free unquantised readings of probe s there; at
    temp_c when given, else at the scenario's temperature)."""
    from inclino.model.scenario import generate_raw

    quiet = copy.deepcopy(s)
    quiet.acc.noise = None
    quiet.mag.noise = None
    quiet.acc.quantisation = None  # the grid's own quantisation (1/16384 g) would add ~0.03 deg
    quiet.mag.quantisation = None  # of azimuth at I = 2 deg, whatever the calibration
    g = runs.li2021_grid((0.0, 120.0, 240.0))
    return g, generate_raw(quiet, *g, temp_c=temp_c)


def _errors(cal, grid, ev):
    c = ref.correct(ev.acc, cal.acc_m, cal.acc_b)
    b = ref.correct(ev.mag, cal.mag_m, cal.mag_b)
    a = ref.attitude(c, b)
    return ref.angle_diff(a["azi"], grid[1]), a["inc"] - grid[0]
