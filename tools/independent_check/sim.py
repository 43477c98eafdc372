"""Independent simulator of a magnetic inclinometer (acc + 3-axis mag).
Truth model (docs/conventions.md): corrected = M @ (raw - b)  =>  raw = inv(M) @ true + b.
Body = C(I,A,T) @ world, NED; gravity reading in NED = [0,0,1] g; field F*[cos dip, 0, sin dip].
"""
import numpy as np

def C_pose(I, A, T):
    I, A, T = np.radians(I), np.radians(A), np.radians(T)
    cI, sI, cA, sA, cT, sT = np.cos(I), np.sin(I), np.cos(A), np.sin(A), np.cos(T), np.sin(T)
    C = np.empty(np.shape(I) + (3, 3))
    C[..., 0, 0] = cT*cI*cA - sT*sA; C[..., 0, 1] = cT*cI*sA + sT*cA; C[..., 0, 2] = -cT*sI
    C[..., 1, 0] = -sT*cI*cA - cT*sA; C[..., 1, 1] = -sT*cI*sA + cT*cA; C[..., 1, 2] = sT*sI
    C[..., 2, 0] = sI*cA; C[..., 2, 1] = sI*sA; C[..., 2, 2] = cI
    return C

def random_rotations(rng, n):
    q = rng.normal(size=(n, 4)); q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.stack([
        np.stack([1-2*(y*y+z*z), 2*(x*y-w*z), 2*(x*z+w*y)], -1),
        np.stack([2*(x*y+w*z), 1-2*(x*x+z*z), 2*(y*z-w*x)], -1),
        np.stack([2*(x*z-w*y), 2*(y*z+w*x), 1-2*(x*x+y*y)], -1)], -2)
    return R

def pose_from_C(C):
    """inc, azi, tf (deg) of a body<-world rotation C."""
    I = np.degrees(np.arccos(np.clip(C[..., 2, 2], -1, 1)))
    A = np.degrees(np.arctan2(C[..., 2, 1], C[..., 2, 0])) % 360
    T = np.degrees(np.arctan2(C[..., 1, 2], -C[..., 0, 2])) % 360
    return I, A, T

def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])

def rot_small(w):
    from scipy.linalg import expm
    return expm(skew(w))

def draw_truth(rng, acc_sym=True, mag_sym=False, mag_rot=True):
    """Truth per triad: M (correction matrix), b (raw units)."""
    def sym_M(scale_sd, cross_sd):
        D = np.diag(1 + rng.normal(0, scale_sd, 3))
        E = rng.normal(0, cross_sd, (3, 3)); E = (E + E.T) / 2; np.fill_diagonal(E, 0)
        return D + E
    Ma = sym_M(0.01, 0.005)
    if not acc_sym:
        Ma = rot_small(rng.normal(0, np.radians(0.3), 3)) @ Ma
    ba = rng.normal(0, 0.01, 3)                 # g
    Sm = sym_M(0.02, 0.01)
    Mm = Sm
    if mag_rot and not mag_sym:
        Mm = rot_small(rng.normal(0, np.radians(1.0), 3)) @ Sm
    bm = rng.normal(0, 500, 3)                  # nT
    return dict(Ma=Ma, ba=ba, Mm=Mm, bm=bm)

def readings(truth, Cs, F, dip, G=1.0):
    g = Cs @ np.array([0, 0, G])
    f = F * np.array([np.cos(np.radians(dip)), 0, np.sin(np.radians(dip))])
    m = Cs @ f
    acc = np.linalg.solve(truth['Ma'], g.T).T + truth['ba']
    mag = np.linalg.solve(truth['Mm'], m.T).T + truth['bm']
    return acc, mag, g, m

def write_csv(path, cols, header=None, fmt='%.9g'):
    names = list(cols)
    data = np.column_stack([np.asarray(cols[k], float) for k in names])
    with open(path, 'w') as fh:
        for k, v in (header or {}).items():
            fh.write(f'# {k}={v}\n')
        fh.write(','.join(names) + '\n')
        np.savetxt(fh, data, delimiter=',', fmt=fmt)
