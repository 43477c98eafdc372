import json, os, sys
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sim import *

F0, DIP0 = 50000.0, 60.0

def make_case(case, seed, path):
    """Returns truth dict and writes the CSV.  case in acc, both, mag, poses, cluster_acc, cluster_both, cluster_poses"""
    rng = np.random.default_rng(seed)
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
