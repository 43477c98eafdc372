import json, sys, numpy as np, collections
files = sys.argv[1:]
R = collections.defaultdict(list)
for f in files:
    for l in open(f):
        r = json.loads(l); R[r['case']].append(r)
def cls(k):
    if k == 'dip': return 'dip'
    tri, rest = k[:3], k[4:]
    if rest[0] == 'b': return tri + '_bias'
    return tri + ('_scale' if rest[1] == rest[2] else '_cross')
for case, rs in R.items():
    ok = [r for r in rs if 'z' in r]
    print(f'== {case}: {len(rs)} runs, {len(ok)} fitted, rc {collections.Counter(r["rc"] for r in rs)}, '
          f'secs {np.mean([r["secs"] for r in rs]):.1f}, outliers/run {np.mean([r.get("n_out",0) for r in ok]):.1f}')
    for r in rs:
        if r.get('stderr'): print('   stderr seed', r['seed'], r['stderr'][-300:])
    zc = collections.defaultdict(list)
    for r in ok:
        for k, v in r['z'].items(): zc[cls(k)].append(v)
    print('   z RMS: ' + ', '.join(f'{k} {np.sqrt(np.mean(np.square(v))):.2f} (max|z| {np.max(np.abs(v)):.1f}, n={len(v)})' for k, v in sorted(zc.items())))
    pairs = [('cal_fit_only_inc', 'predicted_inc_rms_fit_only_deg'), ('cal_fit_only_azi', 'predicted_azi_rms_fit_only_deg'),
             ('cal_mount_inc', 'predicted_inc_rms_deg'), ('cal_mount_azi', 'predicted_azi_rms_deg'),
             ('acc_inc', 'acc_inc'), ('acc_azi', 'acc_azi'), ('heldout_g_rms', 'reading_noise_acc_g'), ('heldout_b_rms', 'reading_noise_mag_nT')]
    if all('predicted_inc_rms_fit_only_deg' not in r['pred'] for r in ok):
        pairs[0] = ('cal_fit_only_inc', 'predicted_inc_rms_deg'); pairs[1] = ('cal_fit_only_azi', 'predicted_azi_rms_deg')
    for a, p in pairs:
        x = [(r['ach'][a], r['pred'][p]) for r in ok if a in r['ach'] and r['pred'].get(p) is not None]
        if not x: continue
        x = np.array(x)
        print(f'   {a:18s} vs {p:32s}: pooled {np.sqrt(np.mean(x[:,0]**2)/np.mean(x[:,1]**2)):.2f}  median {np.median(x[:,0]/x[:,1]):.2f}  '
              f'(10-90% {np.percentile(x[:,0]/x[:,1],10):.2f}-{np.percentile(x[:,0]/x[:,1],90):.2f}; ach {np.sqrt(np.mean(x[:,0]**2)):.4g} pred {np.sqrt(np.mean(x[:,1]**2)):.4g})')
