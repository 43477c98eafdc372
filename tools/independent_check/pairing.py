"""The triads' row pairing on independently simulated logs: each draw of a
case (gen.py's own simulator, no code of the package) is written in the
canonical columns, its magnetometer columns shifted by k rows (the rows
the shift leaves unpaired dropped, as when two files are joined), and
`inclino import LOG -o RUN.csv --json` (the default description: the
canonical columns as they are) checks it before any fit.  Per case and
shift: how many draws name the shift with its lag (a warning or an error),
name another lag (wrong), say something of the pairing (a note: "possible",
"not checked to a row", "about k rows") and say nothing.  For an in-step
log (k = 0) a named lag is wrong and a note is counted as said.

    cd tools/independent_check
    INCLINO=../../.venv/bin/inclino OUTDIR=/tmp/icp python pairing.py positions,holds,moving 0 10

Cases: positions (24-60 random orientations, one row each: a gimbal's
positions), holds (24-60 holds of 1-50 rows, no rows between them),
moving (gen.make_moving: a hand tumble at 100 rows/s, 5-20 mg of the
hand's acceleration)."""
import json
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen  # noqa: E402

INCLINO = os.environ.get('INCLINO', 'inclino')
OUT = os.environ.get('OUTDIR', 'independent-check-out')
SHIFTS = (0, 1, -1, 2, -2, 5, -5, 20)
CASES = {'positions': ('both', {'ROWS1': ''}), 'holds': ('both', {}), 'moving': ('moving_both', {})}
MAG = ('mx_nT', 'my_nT', 'mz_nT')


def read(path):
    with open(path) as fh:
        lines = fh.read().splitlines()
    head = [ln for ln in lines if ln.startswith('#')]
    names = next(ln for ln in lines if not ln.startswith('#')).split(',')
    data = np.loadtxt(path, delimiter=',', comments='#', skiprows=len(head) + 1, ndmin=2)
    return head, names, data


def shifted(src, k, dst):
    """The magnetometer's rows k behind: its row i + k is the accelerometer's
    row i's (the lag the checks name, and `[magnetometer] lag = k` undoes)."""
    head, names, data = read(src)
    out = data.copy()
    cols = [names.index(c) for c in MAG]
    out[:, cols] = np.roll(data[:, cols], k, axis=0)
    out = out[k:] if k > 0 else out[:len(out) + k]
    with open(dst, 'w') as fh:
        fh.write(''.join(h + '\n' for h in head) + ','.join(names) + '\n')
        np.savetxt(fh, out, delimiter=',', fmt='%.9g')


def judge(k, rep):
    found = [f for f in rep['checks']['findings']
             if f['check'] == 'row-alignment' or 'pairing' in f['message'] or 'paired out of step' in f['message']]
    named = [f['figures'].get('lag_rows') for f in found if f['level'] in ('error', 'warning')
             and 'lag_rows' in f['figures']]
    if named:
        return 'named' if named[0] == k else 'wrong'
    return 'said' if found else 'silent'


def main(cases, first, count):
    os.makedirs(OUT, exist_ok=True)
    tally = {}
    for case in cases:
        kind, env = CASES[case]
        for seed in range(first, first + count):
            if case == 'positions':
                os.environ['ROWS1'] = str(int(np.random.default_rng(seed).integers(24, 61)))
            else:
                os.environ.pop('ROWS1', None)
            src = f'{OUT}/{case}_{seed}.csv'
            gen.make_case(kind, seed, src)
            for k in SHIFTS:
                log = f'{OUT}/{case}_{seed}_k{k}.csv'
                shifted(src, k, log)
                p = subprocess.run(['nice', '-n', '5', INCLINO, 'import', log, '-o', log + '.run.csv', '--json'],
                                   capture_output=True, text=True)
                lag = re.search(r'paired out of step: .*lag = (-?\d+)', p.stderr)
                if p.returncode == 2 and lag and 'Traceback' not in p.stderr:
                    # refused before any fit (the checks' error): the lag it names
                    res = 'named' if int(lag.group(1)) == k else 'wrong'
                elif p.returncode != 0 or 'Traceback' in p.stderr:
                    res = f'exit {p.returncode}'
                else:
                    res = judge(k, json.loads(p.stdout))
                tally.setdefault((case, k), []).append(res)
    print(f"{'case':10s} {'shift':>5s}  named  wrong  said  silent  other")
    for (case, k), r in tally.items():
        other = sum(x.startswith('exit') for x in r)
        print(f"{case:10s} {k:+5d}  {r.count('named'):5d}  {r.count('wrong'):5d}  {r.count('said'):4d}  "
              f"{r.count('silent'):6d}  {other:5d}")


if __name__ == '__main__':
    main(sys.argv[1].split(','), int(sys.argv[2]), int(sys.argv[3]))
