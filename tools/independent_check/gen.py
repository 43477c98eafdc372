import json, os, sys
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sim import *

F0, DIP0 = 50000.0, 60.0

def make_case(case, seed, path):
    """Returns truth dict and writes the CSV.  case in acc, both, mag, poses, cluster_acc, cluster_both, cluster_poses"""
    rng = np.random.default_rng(seed)
    if case.startswith('moving'):
        return make_moving(case, rng, path)
    poses = case.startswith('poses') or case == 'cluster_poses'
    tr = draw_truth(rng, acc_sym=not poses, mag_sym=(case == 'mag'))
    nh = int(rng.integers(24, 61))
    clustered = case.startswith('cluster')
    rows = rng.integers(20, 51, nh) if clustered else rng.integers(1, 51, nh)
    if __import__('os').environ.get('ROWS1'):
        nh = int(__import__('os').environ['ROWS1']); rows = np.ones(nh, int)
    sa = 1e-3 if not clustered else 0.5e-3
    sm = float(rng.uniform(50, 200)) if not clustered else 50.0
    import os as _os
    if _os.environ.get('SA'): sa = float(_os.environ['SA'])
    if _os.environ.get('SM'): sm = float(_os.environ['SM'])
    ha, hm = (1e-3, float(__import__('os').environ.get('HM', '100'))) if clustered else (0.0, 0.0)     # per-hold offsets
    if poses:
        # turntable: indicated poses; true = indicated + 0.05 deg error per axis per pose
        I = np.degrees(np.arccos(rng.uniform(-1, 1, nh)))
        A = rng.uniform(0, 360, nh); T = rng.uniform(0, 360, nh)
        pe = float(__import__('os').environ.get('POSE_ERR', '0.05'))
        ax = [float(v) for v in __import__('os').environ.get('POSE_AXES', '1,1,1').split(',')]
        Ct = C_pose(I + ax[0] * rng.normal(0, pe, nh), A + ax[1] * rng.normal(0, pe, nh), T + ax[2] * rng.normal(0, pe, nh))
    else:
        Ct = random_rotations(rng, nh)
        I, A, T = pose_from_C(Ct)
    idx = np.repeat(np.arange(nh), rows)
    n = len(idx)
    acc, mag, g, m = readings(tr, Ct[idx], F0, DIP0)
    acc = acc + rng.normal(0, sa, acc.shape) + rng.normal(0, 1, (nh, 3))[idx] * ha
    mag = mag + rng.normal(0, sm, mag.shape) + rng.normal(0, 1, (nh, 3))[idx] * hm
    cols = dict(t_s=np.arange(n) * 1.0)
    hdr = {}
    if poses:
        cols.update(inc_deg=I[idx], azi_deg=A[idx], tf_deg=T[idx])
    if case != 'mag':
        cols.update(ax_g=acc[:, 0], ay_g=acc[:, 1], az_g=acc[:, 2])
    if case not in ('acc', 'cluster_acc'):
        cols.update(mx_nT=mag[:, 0], my_nT=mag[:, 1], mz_nT=mag[:, 2])
        hdr = dict(field_nT=F0, dip_deg=DIP0)
    write_csv(path, cols, header=hdr)
    tr.update(sa=sa, sm=sm, ha=ha, hm=hm, nh=nh, n=n, poses=poses)
    return tr


def band_noise(rng, n, lo_hz, hi_hz, rate, rms, dims=3):
    """White noise filtered to lo..hi Hz (FFT), scaled to rms per axis."""
    f = np.fft.rfftfreq(n, 1.0 / rate)
    X = np.fft.rfft(rng.normal(size=(n, dims)), axis=0)
    X[(f < lo_hz) | (f > hi_hz)] = 0.0
    x = np.fft.irfft(X, n=n, axis=0)
    return x * (rms / x.std(0))


def make_moving(case, rng, path):
    """A hand-held tumble read while moving: 30-80 s at 100 rows/s, the
    sensor turned continuously (body rate band-limited to 0.2-1 Hz, 40-90
    deg/s RMS per axis), with the hand's own acceleration (0.5-5 Hz, 5-20 mg
    RMS per axis) on the accelerometer, 1 mg and 50-200 nT white noise."""
    from scipy.spatial.transform import Rotation
    rate = 100.0
    n = int(rng.integers(3000, 8001))
    tr = draw_truth(rng, acc_sym=True, mag_sym=(case == 'moving_mag'))
    w = np.radians(band_noise(rng, n, 0.2, 1.0, rate, float(rng.uniform(40, 90))))  # body rate, rad/s
    C = np.empty((n, 3, 3))
    C[0] = random_rotations(rng, 1)[0]
    steps = Rotation.from_rotvec(-w / rate).as_matrix()  # body <- world: C' = -[w x] C
    for i in range(1, n):
        C[i] = steps[i - 1] @ C[i - 1]
    hand = float(rng.uniform(5, 20)) * 1e-3
    a = band_noise(rng, n, 0.5, 5.0, rate, hand)  # g, body axes
    acc, mag, g, m = readings(tr, C, F0, DIP0)
    acc = acc + np.linalg.solve(tr['Ma'], a.T).T  # the hand's specific force, read through the triad
    sa, sm = 1e-3, float(rng.uniform(50, 200))
    acc = acc + rng.normal(0, sa, acc.shape)
    mag = mag + rng.normal(0, sm, mag.shape)
    cols = dict(t_s=np.arange(n) / rate)
    hdr = {}
    if case != 'moving_mag':
        cols.update(ax_g=acc[:, 0], ay_g=acc[:, 1], az_g=acc[:, 2])
    if case != 'moving_acc':
        cols.update(mx_nT=mag[:, 0], my_nT=mag[:, 1], mz_nT=mag[:, 2])
        hdr = dict(field_nT=F0, dip_deg=DIP0)
    write_csv(path, cols, header=hdr)
    tr.update(sa=sa, sm=sm, ha=0.0, hm=0.0, hand=hand, nh=0, n=n, poses=False)
    return tr
