"""NumPy golden model of the firmware's fixed-point core.

Each function mirrors, step for step, the C function of the same name in
firmware/src (same shifts, same rounding, same saturation, same table), over
arrays of any length.  Values are carried in int64 arrays; every result is
checked to be what the C computes in 32 bits.  The contracts (Q formats,
rounding, error bounds) are in the C headers and docs/fixed-point.md.

Saturation flags are returned as boolean arrays alongside the values.
"""
from __future__ import annotations

import math

import numpy as np

INT32_MAX = 2**31 - 1
INT32_MIN = -(2**31)
U32 = 2**32

# attitude.h flags
F_NEAR_VERTICAL = 0x0001
F_ACC_OVERRANGE = 0x0002
F_MAG_OVERRANGE = 0x0004
F_ACC_SATURATED = 0x0008
F_MAG_SATURATED = 0x0010
F_ARITH_SATURATED = 0x0020
F_ZERO_GRAVITY = 0x0040
F_ZERO_FIELD = 0x0080
FLAG_NAMES = {
    F_NEAR_VERTICAL: "near-vertical",
    F_ACC_OVERRANGE: "acc-overrange",
    F_MAG_OVERRANGE: "mag-overrange",
    F_ACC_SATURATED: "acc-saturated",
    F_MAG_SATURATED: "mag-saturated",
    F_ARITH_SATURATED: "arith-saturated",
    F_ZERO_GRAVITY: "zero-gravity",
    F_ZERO_FIELD: "zero-field",
}

NEAR_VERTICAL_Q16 = 32768
ACC_RANGE_COUNTS = 27853
MAG_RANGE_COUNTS = 100000
IN_FRAC_BITS = 6  # raw readings are Q6 counts (correct.h CORR_IN_FRAC_BITS)
IN_ONE = 1 << IN_FRAC_BITS
ACC_RAW_MAX = 32767 * IN_ONE
ACC_RAW_MIN = -32768 * IN_ONE
MAG_RAW_MAX = (2**20 - 1) * IN_ONE
MAG_RAW_MIN = -(2**20) * IN_ONE
ACC_IN_SHIFT = 9  # Q6 counts (2^-20 g) -> Q29 g
MAG_IN_SHIFT = 4  # Q6 counts (2^-6 nT) -> Q10 nT
M_ONE = 2**29
ATAN_N = 256
DIV_BITS = 20
ATAN_FRAC_BITS = 12
# temperature terms (correct.h)
TEMP_RAW_ZERO = 1331  # TEMP_OUT count at 0 degC
TEMP_K = 30802        # 0.94 in Q15: Q6 counts -> Q7 degC
E_MAX = 2**29 - 256   # |r(T) - 1| <= 1 - 2^-21 in Q29 (correct.h CORR_E_MAX)


def deg_q16(d):
    return int(d) * 65536


def _i64(x):
    return np.asarray(x, dtype=np.int64)


def flag_names(flags: int) -> list[str]:
    return [name for bit, name in FLAG_NAMES.items() if flags & bit]


# --------------------------------------------------------------- fx_ops
def fx_mul16(a, b):
    return _i64(a) * _i64(b)


def fx_asr32(x, n):
    return np.right_shift(_i64(x), _i64(n))  # int64 >> is floor


def fx_asr32_rnd(x, n):
    x = _i64(x)
    n = np.broadcast_to(_i64(n), x.shape)
    q = np.right_shift(x, n)
    bit = np.right_shift(x & 0xFFFFFFFF, np.maximum(n - 1, 0)) & 1
    return np.where(n == 0, x, q + bit)


def _sat32(v):
    sat = (v > INT32_MAX) | (v < INT32_MIN)
    return np.clip(v, INT32_MIN, INT32_MAX), sat


def fx_shl32_sat(x, n):
    return _sat32(_i64(x) * np.left_shift(np.int64(1), _i64(n)))


def fx_add32_sat(a, b):
    return _sat32(_i64(a) + _i64(b))


def fx_sub32_sat(a, b):
    return _sat32(_i64(a) - _i64(b))


def fx_mul32_q31(a, b):
    """Returns (result, saturated)."""
    a = _i64(a)
    b = _i64(b)
    ah = a >> 16
    bh = b >> 16
    al = (a & 0xFFFF) >> 1
    bl = (b & 0xFFFF) >> 1
    s = fx_mul16(ah, bh) + (fx_mul16(ah, bl) >> 15) + (fx_mul16(al, bh) >> 15)
    hi = s > 0x3FFFFFFF
    lo = s < -0x40000000
    r = np.where(hi, INT32_MAX, np.where(lo, INT32_MIN, s * 2))
    return r, hi | lo


def fx_dot3_q31(a, b):
    """a, b: (..., 3).  sat(sat(p0 + p1) + p2) with p_i = fx_mul32_q31(a_i, b_i).
    Returns (result, saturated)."""
    a = _i64(a)
    b = _i64(b)
    p0, s0 = fx_mul32_q31(a[..., 0], b[..., 0])
    p1, s1 = fx_mul32_q31(a[..., 1], b[..., 1])
    p2, s2 = fx_mul32_q31(a[..., 2], b[..., 2])
    acc, s3 = fx_add32_sat(p0, p1)
    acc, s4 = fx_add32_sat(acc, p2)
    return acc, s0 | s1 | s2 | s3 | s4


# --------------------------------------------------------------- fx_math
def atan_table() -> np.ndarray:
    """round(atan(k/256) * 180/pi * 65536), k = 0..256 (Python's round, as
    tools/gen_atan_table.py writes it)."""
    return np.array([round(math.degrees(math.atan(k / ATAN_N)) * 65536)
                     for k in range(ATAN_N + 1)], dtype=np.int64)


_ATAN = atan_table()


def fx_div_frac_q20(num, den):
    num = _i64(num)
    den = _i64(den)
    num, den = np.broadcast_arrays(num, den)
    rem = num.copy()
    q = np.zeros_like(num)
    for _ in range(DIV_BITS):
        rem = rem * 2  # exact in int64; the C keeps the 33rd bit as `top`
        q = q * 2
        ge = rem >= den
        rem = np.where(ge, rem - den, rem)
        q = q + ge
    q = q + (rem >= den - rem)
    q = np.where(num >= den, 1 << DIV_BITS, q)
    return np.where(den == 0, 0, q)


def fx_isqrt_u32(x):
    x = _i64(x).copy()
    res = np.zeros_like(x)
    bit = np.int64(1 << 30)
    for _ in range(16):
        ge = x >= res + bit
        x = np.where(ge, x - (res + bit), x)
        res = np.where(ge, (res >> 1) + bit, res >> 1)
        bit >>= 2
    return res


def fx_sqrt_u32_q8(x):
    x = _i64(x)
    k = np.zeros(x.shape, dtype=np.int64)
    xn = x.copy()
    for _ in range(15):
        small = (xn < (1 << 30)) & (xn > 0)
        xn = np.where(small, xn << 2, xn)
        k = k + small
    y = fx_isqrt_u32(xn)
    r = xn - y * y
    s = (y << 8) + ((r << 8) + y) // (2 * y + 1)
    half = np.where(k > 0, np.left_shift(1, np.maximum(k - 1, 0)), 0)
    out = np.where(k > 0, (s + half) >> k, s)
    return np.where(x == 0, 0, out)


def fx_atan2_q16(y, x):
    y = _i64(y)
    x = _i64(x)
    y, x = np.broadcast_arrays(y, x)
    ux = np.abs(x)
    uy = np.abs(y)
    swap = uy > ux
    num = np.where(swap, ux, uy)
    den = np.where(swap, uy, ux)
    q = fx_div_frac_q20(num, den)
    idx = q >> ATAN_FRAC_BITS
    frac = q & ((1 << ATAN_FRAC_BITS) - 1)
    t0 = _ATAN[idx]
    t1 = _ATAN[np.minimum(idx + 1, ATAN_N)]
    a = np.where(frac != 0, t0 + fx_asr32_rnd(fx_mul16(t1 - t0, frac), ATAN_FRAC_BITS), t0)
    a = np.where(swap, deg_q16(90) - a, a)
    a = np.where(x < 0, deg_q16(180) - a, a)
    a = np.where(y < 0, deg_q16(360) - a, a)
    a = np.where(a == deg_q16(360), 0, a)
    return np.where((x == 0) & (y == 0), 0, a)


# --------------------------------------------------------------- correct
def corr_triad(x, m, bias):
    """x: (..., 3) scaled raw; m: (..., 9) Q29; bias: (..., 3).
    Returns (out (..., 3), saturated (...))."""
    x = _i64(x)
    m = _i64(m)
    bias = _i64(bias)
    d, sat = fx_sub32_sat(x, bias)
    sat = sat.any(axis=-1)
    out = []
    for i in range(3):
        acc, s = fx_dot3_q31(m[..., 3 * i:3 * i + 3], d)
        sat = sat | s
        out.append(acc)
    return np.stack(out, axis=-1), sat


def corr_temp_dt(temp_q6, t_ref):
    """correct.c corr_temp_dt: TEMP_OUT mean (Q6 counts) -> dT Q7 degC.
    Returns (dT (...), saturated (...))."""
    t = _i64(temp_q6)
    z = TEMP_RAW_ZERO * IN_ONE
    u = np.clip(z - t, -32767, 32767)
    sat = (z - t > 32767) | (z - t < -32767)
    T = fx_asr32_rnd(fx_mul16(u, TEMP_K), 15) - _i64(t_ref)
    sat = sat | (T > 32767) | (T < -32767)
    return np.clip(T, -32767, 32767), sat


def corr_temp_eval(dt, bias, c1, c2, r1, r2):
    """correct.c corr_temp_eval: one triad's terms at dT (Q7).  dt (...);
    bias, c1..r2 (..., 3).  Returns (beff (..., 3), e (..., 3), saturated (...))."""
    dt = _i64(dt)[..., None]
    dts = dt * 32768
    tb, s0 = fx_mul32_q31(_i64(c1) + fx_mul16(c2, dt), dts)
    beff, s1 = fx_add32_sat(bias, tb)
    e, s3 = fx_mul32_q31(_i64(r1) + fx_mul16(r2, dt), dts)
    s2 = (e > E_MAX) | (e < -E_MAX)
    return beff, np.clip(e, -E_MAX, E_MAX), (s0 | s1 | s2 | s3).any(axis=-1)


def corr_triad_temp(x, m, beff, e):
    """correct.c corr_triad_temp: out = M (r(T) (x - b - bias(T))).
    Returns (out (..., 3), saturated (...))."""
    v, s1 = fx_sub32_sat(x, beff)
    p, s2 = fx_mul32_q31(v, e)
    d, s3 = fx_add32_sat(v, p * 4)
    sat = (s1 | s2 | s3).any(axis=-1)
    m = _i64(m)
    out = []
    for i in range(3):
        acc, s = fx_dot3_q31(m[..., 3 * i:3 * i + 3], d)
        sat = sat | s
        out.append(acc)
    return np.stack(out, axis=-1), sat


# --------------------------------------------------------------- attitude
def att_norm3(v):
    """Returns (out (..., 3), s (...))."""
    v = _i64(v)
    m = np.abs(v).max(axis=-1)
    s = np.zeros(m.shape, dtype=np.int64)
    mm = m.copy()
    for _ in range(2):
        big = mm >= (1 << 30)
        mm = np.where(big, mm >> 1, mm)
        s = s - big
    for _ in range(30):
        small = (mm < (1 << 29)) & (mm > 0)
        mm = np.where(small, mm << 1, mm)
        s = s + small
    se = s[..., None]
    left, _ = fx_shl32_sat(v, np.maximum(se, 0))
    right = fx_asr32_rnd(v, np.maximum(-se, 0))
    out = np.where(se >= 0, left, right)
    return out, s


def _mag_from_sq(q):
    q = np.maximum(_i64(q), 0)
    return fx_sqrt_u32_q8(2 * q) * 128


def _denorm(v, s):
    right = fx_asr32_rnd(v, np.maximum(s, 0))
    left, sat = fx_shl32_sat(v, np.maximum(-s, 0))
    return np.where(s >= 0, right, left), (s < 0) & sat


def att_compute(g, b):
    """g: (..., 3) Q27 g; b: (..., 3) Q8 nT.  Returns a dict of int64 arrays:
    inc, azi, gtf, mtf, gt, bt, dip, flags."""
    G, sg = att_norm3(g)
    B, sb = att_norm3(b)
    flags = np.zeros(sg.shape, dtype=np.int64)
    flags |= np.where((G == 0).all(axis=-1), F_ZERO_GRAVITY, 0)
    flags |= np.where((B == 0).all(axis=-1), F_ZERO_FIELD, 0)
    Gh = G.copy()
    Gh[..., 2] = 0
    H, sh = att_norm3(Gh)
    sat = np.zeros(sg.shape, dtype=bool)

    def mul(a, c):
        nonlocal sat
        r, s = fx_mul32_q31(a, c)
        sat = sat | s
        return r

    def dot(a, c):
        nonlocal sat
        r, s = fx_dot3_q31(a, c)
        sat = sat | s
        return r

    Gz = G[..., 2]
    Bx, By, Bz = B[..., 0], B[..., 1], B[..., 2]
    Hx, Hy = H[..., 0], H[..., 1]
    g2 = dot(G, G)
    gmag = _mag_from_sq(g2)
    h2 = dot(H, H)
    hmag = _mag_from_sq(h2)
    r = fx_asr32_rnd(hmag, sh + 1)
    out = {}
    out["inc"] = fx_atan2_q16(r, fx_asr32_rnd(Gz, 1))
    out["gtf"] = fx_atan2_q16(G[..., 1], -G[..., 0])
    cross = mul(Hx, By) - mul(Hy, Bx)
    doth = dot(H, B)
    num = mul(gmag, cross)
    den = fx_asr32_rnd(mul(Bz, h2), sh + 1) - fx_asr32_rnd(mul(Gz, doth), 1)
    out["azi"] = fx_atan2_q16(fx_asr32_rnd(num, 1), den)
    out["mtf"] = fx_atan2_q16(-By, Bx)
    # dip = atan2(G.B, |G x B|), |G x B|^2 = |G|^2 |B|^2 - (G.B)^2
    gdotb = dot(G, B)
    b2 = dot(B, B)
    c2 = mul(g2, b2) - mul(gdotb, gdotb)
    cmag = _mag_from_sq(c2)
    dip = fx_atan2_q16(gdotb, cmag)
    out["dip"] = np.where(dip > deg_q16(180), dip - deg_q16(360), dip)
    bmag = _mag_from_sq(b2)
    out["gt"], s1 = _denorm(gmag, sg)
    out["bt"], s2 = _denorm(bmag, sb)
    sat = sat | s1 | s2
    inc = out["inc"]
    flags |= np.where((inc < NEAR_VERTICAL_Q16) | (inc > deg_q16(180) - NEAR_VERTICAL_Q16),
                      F_NEAR_VERTICAL, 0)
    flags |= np.where(sat, F_ARITH_SATURATED, 0)
    out["flags"] = flags
    return out


# --------------------------------------------------------------- survey
def to_q6(counts):
    """Whole or fractional counts -> the firmware's Q6 readings, rounded half
    up as acq_avg_q6 rounds a mean (floor(64 x + 1/2))."""
    return np.floor(np.asarray(counts, dtype=float) * IN_ONE + 0.5).astype(np.int64)


def acq_avg_q6(sum_, n):
    """acquire.c acq_avg_q6: floor(64 sum / n + 1/2), exact in integers."""
    s = _i64(sum_)
    n = _i64(n)
    return np.floor_divide(2 * IN_ONE * s + n, 2 * n)


def corr_in_acc(raw_q6):
    return _i64(raw_q6) << ACC_IN_SHIFT


def corr_in_mag(raw_q6):
    return _i64(raw_q6) << MAG_IN_SHIFT


def survey_compute(acc, mag, cal_acc_m, cal_acc_b, cal_mag_m, cal_mag_b, temp=None, temp_q6=None):
    """acc: (n, 3) int Q6 accelerometer counts; mag: (n, 3) int Q6 fluxgate
    counts (whole counts c are c * IN_ONE); coefficients as int arrays (9,),
    (3,) broadcast over n.  Returns dict with g, b (n, 3) and the
    att_compute keys.  temp (core.FixedTemp) and temp_q6 (n,) TEMP_OUT
    means in Q6 counts: survey_compute_temp (the terms applied; without
    terms, order 0 or temp None, survey_compute's bits)."""
    acc = _i64(acc)
    tt = None
    tsat = np.zeros(acc.shape[:-1], dtype=bool)
    if temp is not None and temp_q6 is not None and int(temp.order) != 0:
        dt, tsat = corr_temp_dt(np.broadcast_to(_i64(temp_q6), acc.shape[:-1]), temp.t_ref)
        ab, ae, sa_ = corr_temp_eval(dt, cal_acc_b, temp.acc_c1, temp.acc_c2, temp.acc_r1, temp.acc_r2)
        mb, me, sm_ = corr_temp_eval(dt, cal_mag_b, temp.mag_c1, temp.mag_c2, temp.mag_r1, temp.mag_r2)
        tsat = tsat | sa_ | sm_
        tt = (ab, ae, mb, me)
    mag = _i64(mag)
    half = IN_ONE // 2
    flags = np.zeros(acc.shape[:-1], dtype=np.int64)
    flags |= np.where((np.abs(acc) > ACC_RANGE_COUNTS * IN_ONE).any(axis=-1), F_ACC_OVERRANGE, 0)
    flags |= np.where(((acc >= ACC_RAW_MAX - half) | (acc < ACC_RAW_MIN + half)).any(axis=-1),
                      F_ACC_SATURATED, 0)
    accc = np.clip(acc, ACC_RAW_MIN, ACC_RAW_MAX)
    if tt is None:
        g, sa = corr_triad(corr_in_acc(accc), cal_acc_m, cal_acc_b)
    else:
        g, sa = corr_triad_temp(corr_in_acc(accc), cal_acc_m, tt[0], tt[1])
    flags |= np.where((np.abs(mag) > MAG_RANGE_COUNTS * IN_ONE).any(axis=-1), F_MAG_OVERRANGE, 0)
    flags |= np.where(((mag >= MAG_RAW_MAX) | (mag <= MAG_RAW_MIN)).any(axis=-1), F_MAG_SATURATED, 0)
    magc = np.clip(mag, MAG_RAW_MIN, MAG_RAW_MAX)
    if tt is None:
        b, sm = corr_triad(corr_in_mag(magc), cal_mag_m, cal_mag_b)
    else:
        b, sm = corr_triad_temp(corr_in_mag(magc), cal_mag_m, tt[2], tt[3])
    flags |= np.where(sa | sm | tsat, F_ARITH_SATURATED, 0)
    out = att_compute(g, b)
    out["flags"] = out["flags"] | flags
    out["g"] = g
    out["b"] = b
    return out


# --------------------------------------------------------------- qc
QC_F_GT, QC_F_BT, QC_F_DIP, QC_F_UNDEFINED = 0x01, 0x02, 0x04, 0x08


def _outside(v, ref, tol):
    d, _ = fx_sub32_sat(v, ref)
    d = np.where(d < 0, np.where(d == INT32_MIN, INT32_MAX, -d), d)
    return d > tol


def qc_check(att, gt_ref, gt_tol, bt_ref, bt_tol, dip_ref, dip_tol):
    f = np.where(_outside(att["gt"], gt_ref, gt_tol), QC_F_GT, 0)
    f |= np.where(_outside(att["bt"], bt_ref, bt_tol), QC_F_BT, 0)
    f |= np.where(_outside(att["dip"], dip_ref, dip_tol), QC_F_DIP, 0)
    bad = (_i64(att["flags"]) & (F_ZERO_GRAVITY | F_ZERO_FIELD | F_ARITH_SATURATED)) != 0
    return f | np.where(bad, QC_F_UNDEFINED, 0)
