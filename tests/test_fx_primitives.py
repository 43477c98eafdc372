"""The firmware's primitives (C through cffi) against the golden model bit for
bit, and against exact arithmetic within the error bounds their headers state."""
import math
from fractions import Fraction

import numpy as np
import pytest

from inclino.engines import firmware as core, golden

RNG = np.random.default_rng(20261121)
EDGE32 = np.array([0, 1, -1, 2, -2, 32767, -32768, 65535, -65536, 2**30, -(2**30), 2**31 - 1, -(2**31)])


def test_mul32_matches_golden_and_bound():
    a = np.concatenate([RNG.integers(-(2**31), 2**31, 200_000), np.repeat(EDGE32, len(EDGE32))])
    b = np.concatenate([RNG.integers(-(2**31), 2**31, 200_000), np.tile(EDGE32, len(EDGE32))])
    c, cs = core.mul32_q31(a, b)
    g, gs = golden.fx_mul32_q31(a, b)
    assert np.array_equal(c, g) and np.array_equal(cs, gs)
    # header: -8 < result - a*b/2^31 < 2 whenever it does not saturate
    for i in range(0, len(a), 97):
        if cs[i]:
            continue
        err = int(c[i]) - Fraction(int(a[i]) * int(b[i]), 2**31)
        assert -8 < err < 2, (a[i], b[i], c[i])
    # the one saturating case
    r, s = core.mul32_q31([-(2**31)], [-(2**31)])
    assert r[0] == 2**31 - 1 and s[0]


def test_asr32_rnd_is_round_half_up():
    x = np.concatenate([RNG.integers(-(2**31), 2**31, 5000), EDGE32])
    for n in (0, 1, 2, 7, 15, 16, 30, 31):
        got = core.asr32_rnd(x, n)
        want = [math.floor(Fraction(int(v), 2**n) + Fraction(1, 2)) if n else int(v) for v in x]
        assert got.tolist() == want
        assert np.array_equal(got, golden.fx_asr32_rnd(x, n))


def test_div_frac_q20_exact_rounding():
    den = np.concatenate([RNG.integers(1, 2**32, 20_000, dtype=np.uint64), np.array([1, 2, 3, 2**31, 2**32 - 1], dtype=np.uint64)])
    num = (den * RNG.uniform(0, 1, len(den))).astype(np.uint64)
    num[-5:] = [0, 1, 1, 2**31 - 1, 2**32 - 2]
    got = core.div_frac_q20(num, den)
    assert np.array_equal(got, golden.fx_div_frac_q20(num, den))
    for n, d, q in zip(num[::41].tolist(), den[::41].tolist(), got[::41].tolist()):
        assert q == math.floor(Fraction(n * 2**20, d) + Fraction(1, 2))


def test_sqrt_q8_bound():
    x = np.concatenate([RNG.integers(0, 2**32, 100_000, dtype=np.uint64), np.array([0, 1, 2, 3, 4, 2**32 - 1, 2**30], dtype=np.uint64)])
    got = core.sqrt_u32_q8(x)
    assert np.array_equal(got, golden.fx_sqrt_u32_q8(x))
    exact = np.array([math.sqrt(v) * 256 for v in x.tolist()])
    assert np.abs(got - exact).max() < 1.0


def test_atan2_bound_and_octants():
    y = np.concatenate([RNG.integers(-(2**31), 2**31, 200_000), np.repeat(EDGE32, len(EDGE32))])
    x = np.concatenate([RNG.integers(-(2**31), 2**31, 200_000), np.tile(EDGE32, len(EDGE32))])
    x[:50_000] >>= RNG.integers(0, 31, 50_000)  # small against large
    got = core.atan2_q16(y, x)
    assert np.array_equal(got, golden.fx_atan2_q16(y, x))
    assert got.min() >= 0 and got.max() < 360 * 65536
    ref = np.degrees(np.arctan2(y.astype(float), x.astype(float)))
    err = (got / 65536.0 - ref + 180.0) % 360.0 - 180.0
    nz = (x != 0) | (y != 0)
    assert np.abs(err[nz]).max() <= 0.0003  # header bound
    assert core.atan2_q16([0], [0])[0] == 0
    assert core.atan2_q16([1, 1, 0, -1], [1, 0, -1, 0]).tolist() == [45 * 65536, 90 * 65536, 180 * 65536,
                                                                      270 * 65536]


def test_atan_table_is_the_formula():
    from inclino.engines._core import lib

    c = [lib.fx_atan_table[k] for k in range(257)]
    want = [round(math.degrees(math.atan(k / 256)) * 65536) for k in range(257)]
    assert c == want
    assert np.array_equal(golden.atan_table(), want)
