"""Bit-exactness of the firmware C against the golden model.

`inclino bitexact --vectors N --seed S` runs the whole survey computation
(range checks, correction of both triads, attitude, survey QC) on N random vectors plus
every edge case below, in the C (one batched cffi call per chunk) and in the
golden model, and counts the vectors where any output word differs.  Each
vector also goes through survey_compute_temp (the temperature terms of
calibration image version 2, random terms over their whole ranges) at a
random temperature reading (TEMP_OUT mean in Q6 counts, plausible and
beyond every clamp), and the edge temperatures below.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inclino.engines import firmware as core, golden, reference
from inclino.engines.firmware import SURVEY_COLS, FixedCal, FixedTemp

CHUNK = 250_000


@dataclass
class BitexactResult:
    vectors: int
    mismatches: int
    first_mismatch: int | None = None

    @property
    def line(self) -> str:
        return f"bitexact: {self.vectors} vectors, {self.mismatches} mismatches"


def random_cals(rng, n: int) -> list[FixedCal]:
    """Calibrations from the identity to the edge of the Q29 range, and a
    few that drive every saturation path."""
    q29 = 2**29
    cals = [FixedCal.identity()]
    for k in range(n - 4):
        spread = 0.1 if k % 2 else 1.5
        m_a = np.eye(3) + rng.uniform(-spread, spread, (3, 3))
        m_m = np.eye(3) + rng.uniform(-spread, spread, (3, 3))
        cals.append(FixedCal(
            tuple(int(v) for v in np.clip(np.round(m_a.ravel() * q29), -2**31, 2**31 - 1)),
            tuple(int(v) for v in np.round(rng.uniform(-0.3, 0.3, 3) * 2**29)),
            tuple(int(v) for v in np.clip(np.round(m_m.ravel() * q29), -2**31, 2**31 - 1)),
            tuple(int(v) for v in np.round(rng.uniform(-5000, 5000, 3) * 2**10)),
        ))
    big = tuple([2**31 - 1] * 9)
    neg = tuple([-(2**31)] * 9)
    cals.append(FixedCal(big, (-(2**31),) * 3, big, (-(2**31),) * 3))  # saturating sums
    cals.append(FixedCal(neg, (2**31 - 1,) * 3, neg, (2**31 - 1,) * 3))
    cals.append(FixedCal(tuple([0] * 9), (0, 0, 0), tuple([0] * 9), (0, 0, 0)))  # zero vectors
    return cals


def edge_vectors() -> tuple[np.ndarray, np.ndarray]:
    """Zero and full-scale inputs, over-range, axis-aligned poses, I = 0/90/180,
    near-vertical, field nearly parallel to gravity, rails; in whole counts,
    then as the firmware's Q6 readings (x 64) with the fractions at each
    threshold (one Q6 step and half a count either side of the rails and
    range limits) and inputs beyond the int16 / int32 rails."""
    acc, mag = [], []
    rails_a = [0, 1, -1, 27853, -27853, 27854, -27854, 32767, -32768]
    rails_m = [0, 1, -1, 100000, -100000, 100001, -100001, 2**20 - 1, -(2**20), 2**20, -(2**20) - 1,
               2**23 - 1, -(2**23),
               2**31 - 1, -(2**31)]
    for ra in rails_a:
        for rm in rails_m:
            acc.append([ra, ra, ra])
            mag.append([rm, rm, rm])
            acc.append([ra, 0, -ra])
            mag.append([rm, -rm, 0])
            acc.append([0, 0, ra])
            mag.append([0, rm, 0])
    # axis-aligned and special poses, exact and one count off
    poses = []
    for inc in (0, 0.01, 0.1, 0.49, 0.5, 0.51, 1, 5, 45, 89.99, 90, 90.01, 135, 179.5, 179.99, 180):
        for azi in (0, 45, 90, 180, 270, 359.99):
            for tf in (0, 90, 180, 270):
                poses.append((inc, azi, tf))
    p = np.array(poses, dtype=float)
    for dip in (-89.9, -60, 0, 45.1, 60, 89.9, 89.999, 90):
        g, b = reference.body_vectors(p[:, 0], p[:, 1], p[:, 2], 50000.0, dip)
        a = reference.quantise_acc(g)
        m = reference.quantise_mag(b)
        for off in (0, 1, -1):
            acc.extend((a + off).clip(-32768, 32767).tolist())
            mag.extend((m - off).tolist())
    acc_q = np.array(acc, dtype=np.int64).clip(-32768, 32767) * golden.IN_ONE
    mag_q = np.clip(np.array(mag, dtype=np.int64) * golden.IN_ONE, -(2**31), 2**31 - 1)
    fa, fm = [], []
    one, half = golden.IN_ONE, golden.IN_ONE // 2
    for base in (27853 * one, 32767 * one, -32768 * one, 0):
        for d in (-half - 1, -half, -half + 1, -1, 1, half - 1, half, half + 1):
            fa.append(base + d)
    fa += [2**31 - 1, -(2**31), 2**21, -(2**21) - 1]
    for base in (100000 * one, (2**20 - 1) * one, -(2**20) * one, 0):
        for d in (-half - 1, -half, -1, 1, half, half + 1):
            fm.append(base + d)
    fm += [2**31 - 1, -(2**31)]
    ea, em = [], []
    for x in fa:
        for y in fm[::3]:
            ea.append([x, -x // 3, 16384 * one + 1])
            em.append([y, 7, -y // 5])
    return np.concatenate([acc_q, np.array(ea, dtype=np.int64)]), np.concatenate([mag_q, np.array(em, dtype=np.int64)])


def random_vectors(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Half physically plausible averaged readings of random poses and fields
    (Q6 counts, fractions included), half uniformly random Q6 readings over
    the full input ranges and beyond the rails."""
    h = n // 2
    inc = np.degrees(np.arccos(rng.uniform(-1, 1, h)))
    azi = rng.uniform(0, 360, h)
    tf = rng.uniform(0, 360, h)
    dip = rng.uniform(-90, 90, h)
    F = rng.uniform(20000, 70000, h)
    C = reference.pose_matrix(inc, azi, tf)
    d = np.radians(dip)
    bw = F[:, None] * np.stack([np.cos(d), np.zeros(h), np.sin(d)], -1)
    g = C[..., :, 2] * rng.uniform(0.8, 1.2, (h, 1))
    b = np.einsum("nij,nj->ni", C, bw)
    acc1 = reference.readings_acc(g + rng.normal(0, 0.01, (h, 3)))
    mag1 = reference.readings_mag(b + rng.normal(0, 300, (h, 3)))
    k = n - h
    acc2 = rng.integers(-(2**21) - 5000, 2**21 + 5000, (k, 3))
    mag2 = rng.integers(-(2**29) - 1000, 2**29 + 1000, (k, 3))
    return np.concatenate([acc1, acc2]), np.concatenate([mag1, mag2])


def compare(acc, mag, cals: list[FixedCal]) -> tuple[int, int | None]:
    """Mismatching vectors between C and golden, and the index of the first."""
    c = core.survey(acc, mag, cals)
    idx = np.arange(len(acc)) % len(cals)
    am = np.array([x.acc_m for x in cals], dtype=np.int64)[idx]
    ab = np.array([x.acc_b for x in cals], dtype=np.int64)[idx]
    mm = np.array([x.mag_m for x in cals], dtype=np.int64)[idx]
    mb = np.array([x.mag_b for x in cals], dtype=np.int64)[idx]
    g = golden.survey_compute(acc, mag, am, ab, mm, mb)
    bad = np.zeros(len(acc), dtype=bool)
    for k in SURVEY_COLS[6:]:
        bad |= c[k].astype(np.int64) != g[k]
    bad |= (c["g"] != g["g"]).any(-1) | (c["b"] != g["b"]).any(-1)
    # survey QC against a reference near the vectors' own values (so that
    # both verdicts occur) and against an extreme one (saturating differences)
    for ref in (core.QcRef(bt_ref=50000 * 256, dip_ref=60 * 65536),
                core.QcRef(gt_ref=-(2**31), gt_tol=0, bt_ref=2**31 - 1, bt_tol=2**30, dip_ref=-(2**31),
                           dip_tol=2**31 - 1)):
        qc = golden.qc_check(g, *(getattr(ref, k) for k in ("gt_ref", "gt_tol", "bt_ref", "bt_tol",
                                                             "dip_ref", "dip_tol")))
        bad |= core.qc_check(c, ref) != qc
    first = int(np.argmax(bad)) if bad.any() else None
    return int(bad.sum()), first


def random_temp_cals(rng, cals: list[FixedCal]) -> list[FixedCal]:
    """The calibrations with temperature terms: typical-sized terms, terms
    over their whole ranges (|c1|, |r1| <= 2^30, int16 c2, r2), and the
    range limits (which drive e's clamp and b_eff's saturation)."""
    out = []
    for k, c in enumerate(cals):
        if k % 3 == 0:  # whole ranges
            i32 = lambda: tuple(int(v) for v in rng.integers(-(2**30), 2**30 + 1, 3))  # noqa: E731
            i16 = lambda: tuple(int(v) for v in rng.integers(-(2**15) + 1, 2**15, 3))  # noqa: E731
        elif k % 3 == 1:  # typical (tens of ug/degC, nT/degC, ppm/degC)
            i32 = lambda: tuple(int(v) for v in rng.integers(-(2**24), 2**24, 3))  # noqa: E731
            i16 = lambda: tuple(int(v) for v in rng.integers(-500, 500, 3))  # noqa: E731
        else:  # the limits
            i32 = lambda: tuple(int(v) for v in rng.choice([-(2**30), 2**30, 0], 3))  # noqa: E731
            i16 = lambda: tuple(int(v) for v in rng.choice([-(2**15) + 1, 2**15 - 1, 0], 3))  # noqa: E731
        t = FixedTemp(int(rng.integers(-40 * 128, 125 * 128 + 1)), int(rng.integers(1, 3)),
                      i32(), i16(), i32(), i16(), i32(), i16(), i32(), i16())
        out.append(FixedCal(c.acc_m, c.acc_b, c.mag_m, c.mag_b, t))
    return out


EDGE_TEMPS = (0, 1065 * 64, 1278 * 64, 1416 * 64, 4095 * 64, 1331 * 64 - 32767, 1331 * 64 - 32768,
              1331 * 64 + 32767, 1331 * 64 + 32768, 2**31 - 1, -(2**31))


def random_temps(rng, n: int) -> np.ndarray:
    """TEMP_OUT means in Q6 counts: half over the part's -40..125 degC
    (1065..1416 counts), a quarter over the 12-bit range, a quarter any
    int32; every EDGE_TEMPS value among them."""
    t = np.concatenate([rng.integers(1065 * 64, 1416 * 64 + 1, n - n // 2),
                        rng.integers(0, 4096 * 64, n // 4), rng.integers(-(2**31), 2**31, n // 2 - n // 4)])
    rng.shuffle(t)
    k = min(n, len(EDGE_TEMPS))
    t[:k] = EDGE_TEMPS[:k]
    return t


def per_row_cals(cals: list[FixedCal], idx) -> tuple:
    """The calibrations' coefficients row by row (row i: cals[idx[i]]):
    (acc_m, acc_b, mag_m, mag_b) int64 arrays (n, 9), (n, 3), (n, 9), (n, 3)."""
    return tuple(np.array([getattr(c, k) for c in cals], dtype=np.int64)[idx]
                 for k in ("acc_m", "acc_b", "mag_m", "mag_b"))


def per_row_temp(cals: list[FixedCal], idx) -> FixedTemp:
    """The calibrations' temperature terms row by row (row i: cals[idx[i]],
    each with terms of order 1 or 2): a FixedTemp of arrays, t_ref (n,) and
    the terms (n, 3), which the golden model evaluates row by row as it
    does one calibration's scalars."""
    fields = [f for f in FixedTemp.__dataclass_fields__ if f not in ("t_ref", "order")]
    none = FixedTemp(0, 0, *([(0, 0, 0)] * len(fields)))  # rows of calibrations without terms: not indexed
    temps = [c.temp or none for c in cals]
    return FixedTemp(np.array([t.t_ref for t in temps], dtype=np.int64)[idx], 1,
                     *(np.array([getattr(t, f) for t in temps], dtype=np.int64)[idx] for f in fields))


def golden_temp(acc, mag, temp_q6, cals: list[FixedCal]) -> dict:
    """golden.survey_compute through survey_compute_temp, vector i with
    cals[i % len(cals)]: one call for the vectors whose calibration has
    terms and one for those without (order 0 or none), not one per
    calibration."""
    idx = np.arange(len(acc)) % len(cals)
    has = np.array([c.temp is not None and int(c.temp.order) != 0 for c in cals])[idx]
    out = None
    for sel in (has, ~has):
        if not sel.any():
            continue
        temp = per_row_temp(cals, idx[sel]) if sel is has else None
        g = golden.survey_compute(acc[sel], mag[sel], *per_row_cals(cals, idx[sel]), temp=temp,
                                  temp_q6=temp_q6[sel] if temp is not None else None)
        if out is None:
            out = {k: np.zeros((len(acc),) + v.shape[1:], dtype=v.dtype) for k, v in g.items()}
        for k, v in g.items():
            out[k][sel] = v
    return out


def compare_temp(acc, mag, temp_q6, cals: list[FixedCal]) -> tuple[int, int | None]:
    """As compare, through survey_compute_temp (vector i: cals[i % len])."""
    c = core.survey(acc, mag, cals, temp_q6=temp_q6)
    g = golden_temp(acc, mag, temp_q6, cals)
    bad = np.zeros(len(acc), dtype=bool)
    for col in SURVEY_COLS[6:]:
        bad |= c[col].astype(np.int64) != g[col]
    bad |= (c["g"] != g["g"]).any(-1) | (c["b"] != g["b"]).any(-1)
    first = int(np.argmax(bad)) if bad.any() else None
    return int(bad.sum()), first


def run(vectors: int, seed: int = 1) -> BitexactResult:
    rng = np.random.default_rng(seed)
    cals = random_cals(rng, 64)
    tcals = random_temp_cals(rng, cals)
    ea, em = edge_vectors()
    total = len(ea)
    bad, first = compare(ea, em, cals)
    for t in EDGE_TEMPS:
        b, f = compare_temp(ea, em, np.full(len(ea), t), tcals)
        if f is not None and first is None:
            first = f
        bad += b
    done = 0
    while done < vectors:
        n = min(CHUNK, vectors - done)
        a, m = random_vectors(rng, n)
        b, f = compare(a, m, cals)
        bt, ft = compare_temp(a, m, random_temps(rng, n), tcals)
        f = f if f is not None else ft
        if f is not None and first is None:
            first = total + f
        bad += b + bt  # mismatching (vector, path) pairs
        total += n
        done += n
    return BitexactResult(total, bad, first)
