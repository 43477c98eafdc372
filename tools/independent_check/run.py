"""Harness: for each case and seed, generate data (own simulator), run `inclino calibrate`, compare with truth."""
import sys, json, subprocess, os, time
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen import *

INCLINO = os.environ.get('INCLINO', 'inclino')
OUT = os.environ.get('OUTDIR', 'independent-check-out')
os.makedirs(OUT, exist_ok=True)

def grid():
    inc = [2.0, 5.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
    I, A, T = np.meshgrid(inc, np.arange(0., 360., 60.), [0., 120., 240.], indexing='ij')
    return I.ravel(), A.ravel(), T.ravel()

def attitude(g, b):
    inc = np.degrees(np.arctan2(np.hypot(g[:, 0], g[:, 1]), g[:, 2]))
    ng = np.linalg.norm(g, axis=1)
    azi = np.degrees(np.arctan2(ng * (g[:, 0] * b[:, 1] - g[:, 1] * b[:, 0]),
                                b[:, 2] * (g[:, 0]**2 + g[:, 1]**2) - g[:, 2] * (g[:, 0] * b[:, 0] + g[:, 1] * b[:, 1])))
    return inc, azi % 360

def wrap(d):
    return (d + 180) % 360 - 180

def evaluate(case, seed):
    path = f'{OUT}/{case}_{seed}.csv'
    tr = make_case(case, seed, path)
    cal = f'{OUT}/{case}_{seed}.json'
    t0 = time.time()
    p = subprocess.run(['nice', '-n', '5', INCLINO, 'calibrate', path, '-o', cal], capture_output=True, text=True)
    res = dict(case=case, seed=seed, rc=p.returncode, secs=time.time() - t0, n=tr['n'], nh=tr['nh'])
    if p.returncode not in (0, 1):
        res['stderr'] = p.stderr[-2000:]
        return res
    if 'Traceback' in p.stderr:
        res['stderr'] = p.stderr[-2000:]
    res['stdout'] = p.stdout
    d = json.load(open(cal))
    rep = d['report']; u = rep['uncertainty']
    est = dict(acc_m=np.array(d['acc_m']), acc_b=np.array(d['acc_b']), mag_m=np.array(d['mag_m']), mag_b=np.array(d['mag_b']))
    rng = np.random.default_rng(10_000 + seed)
    Q = np.eye(3)
    if not tr['poses'] and case not in ('acc', 'cluster_acc', 'mag', 'moving_acc', 'moving_mag'):
        # the unobservable common rotation: the data are those of orientations Q^T C (as random), the truth Q M
        Q = rot_small(rng.normal(0, np.radians(0.3), 3))
    tr0 = dict(tr)
    tr = dict(tr, Ma=Q @ tr['Ma'], Mm=Q @ tr['Mm'])
    true = dict(acc_m=tr['Ma'], acc_b=tr['ba'], mag_m=tr['Mm'], mag_b=tr['bm'])
    z = {}
    for k, s in u.get('sigma', {}).items():
        tri, rest = k[:3], k[4:]
        if rest[0] == 'm':
            i, j = int(rest[1]), int(rest[2]); e, t = est[tri + '_m'][i, j], true[tri + '_m'][i, j]
        else:
            i = int(rest[1]); e, t = est[tri + '_b'][i], true[tri + '_b'][i]
        z[k] = (e - t) / s
    if u.get('dip_sigma_deg'):
        z['dip'] = (u['dip_deg'] - DIP0) / u['dip_sigma_deg']
    res['z'] = z
    res['sigma'] = u.get('sigma', {})
    # predictions vs achieved on held-out data with the same truth
    I, A, T = grid()
    C = C_pose(I, A, T)
    has_acc = case not in ('mag', 'moving_mag')
    has_mag = case not in ('acc', 'cluster_acc', 'moving_acc')
    Ma, ba, Mm, bm = (est[k] for k in ('acc_m', 'acc_b', 'mag_m', 'mag_b'))
    def corr(acc, mag):
        return (acc - ba) @ Ma.T, (mag - bm) @ Mm.T
    ach = {}
    # calibration grid: noise-free readings
    mounts = {'fit_only': tr0}
    if not np.allclose(Q, np.eye(3)):
        mounts['mount'] = tr
    for name, trq in mounts.items():
        acc, mag, g0, m0 = readings(trq, C, F0, DIP0)
        g, b = corr(acc, mag)
        inc, azi = attitude(g, b)
        ach[f'cal_{name}_inc'] = float(np.sqrt(np.mean((inc - I)**2)))
        if has_mag and has_acc:
            ach[f'cal_{name}_azi'] = float(np.sqrt(np.mean(wrap(azi - A)**2)))
    # acceptance grid: one reading per position with the run's noise (+ pose error when poses)
    # readings as the run's: its white noise, its per-hold offsets and (a hand tumble) the hand's acceleration,
    # here drawn white at its RMS
    tot_a = np.sqrt(tr['sa'] ** 2 + tr['ha'] ** 2 + tr.get('hand', 0.0) ** 2); tot_m = np.hypot(tr['sm'], tr['hm'])
    reps = 20
    e_i, e_a, ng, nb = [], [], [], []
    for r in range(reps):
        if tr['poses']:
            Ct = C_pose(I + rng.normal(0, .05, I.size), A + rng.normal(0, .05, I.size), T + rng.normal(0, .05, I.size))
        else:
            Ct = C
        acc, mag, _, _ = readings(tr, Ct, F0, DIP0)
        acc = acc + rng.normal(0, tot_a, acc.shape); mag = mag + rng.normal(0, tot_m, mag.shape)
        g, b = corr(acc, mag)
        inc, azi = attitude(g, b)
        e_i.append(inc - I); e_a.append(wrap(azi - A))
        ng.append(np.linalg.norm(g, axis=1) - 1.0); nb.append(np.linalg.norm(b, axis=1) - F0)
    ach['acc_inc'] = float(np.sqrt(np.mean(np.square(e_i))))
    ach['acc_azi'] = float(np.sqrt(np.mean(np.square(e_a))))
    ach['heldout_g_rms'] = float(np.sqrt(np.mean(np.square(ng))))
    ach['heldout_b_rms'] = float(np.sqrt(np.mean(np.square(nb))))
    pred = {}
    for k in ('predicted_azi_rms_deg', 'predicted_inc_rms_deg', 'predicted_azi_rms_fit_only_deg', 'predicted_inc_rms_fit_only_deg'):
        if k in u: pred[k] = u[k]
    if 'prediction_acceptance_grid' in u:
        pred['acc_azi'] = u['prediction_acceptance_grid']['azi_rms_deg']
        pred['acc_inc'] = u['prediction_acceptance_grid']['inc_rms_deg']
    if 'reading_noise' in u:
        pred['reading_noise_acc_g'] = u['reading_noise'].get('acc_g'); pred['reading_noise_mag_nT'] = u['reading_noise'].get('mag_nT')
    pred['noise'] = rep.get('noise')
    res['ach'] = ach; res['pred'] = pred
    res['rows_used'] = rep.get('rows_used'); res['n_out'] = len(rep.get('outliers') or [])
    res['tot_a'] = tot_a; res['tot_m'] = tot_m
    return res

if __name__ == '__main__':
    if len(sys.argv) < 4:
        sys.exit('usage: run.py CASES(comma-separated) SEED_FROM SEED_TO [TAG]   (README.md)')
    cases = sys.argv[1].split(',')
    seeds = range(int(sys.argv[2]), int(sys.argv[3]))
    tag = sys.argv[4] if len(sys.argv) > 4 else 'res'
    with open(f'{OUT}/{tag}.jsonl', 'a') as fh:
        for case in cases:
            for s in seeds:
                r = evaluate(case, s)
                fh.write(json.dumps(r) + '\n'); fh.flush()
                os.remove(f'{OUT}/{case}_{s}.csv')
