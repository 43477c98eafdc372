"""The firmware core on the S08 (SDCC -ms08, ucsim shc08): bit for bit equal to
the golden model on >= 10 000 vectors, including every edge case of the host
bit-exact suite (inclino.bitexact.edge_vectors and the saturating
calibrations of random_cals)."""
import numpy as np
import pytest

from inclino import bitexact, golden, mcu

if mcu.tools_missing():
    pytest.skip(mcu.MISSING_REASON, allow_module_level=True)

I32 = (-(2**31), 2**31 - 1)


@pytest.fixture(scope="module")
def fw(tmp_path_factory):
    return mcu.build(tmp_path_factory.mktemp("s08"))


def _mismatch_report(got: dict, want: dict, keys) -> tuple[int, str]:
    n = len(next(iter(got.values())))
    bad = np.zeros(n, dtype=bool)
    per = {}
    for k in keys:
        d = np.asarray(got[k]) != np.asarray(want[k])
        d = d.reshape(n, -1).any(axis=1)
        per[k] = int(d.sum())
        bad |= d
    first = int(np.argmax(bad)) if bad.any() else None
    return int(bad.sum()), f"per field {per}, first at {first}"


def test_survey_bit_exact_on_s08(fw):
    rng = np.random.default_rng(2024)
    cals = bitexact.random_cals(rng, 8)  # identity, 4 random, 3 saturating/zero
    ea, em = bitexact.edge_vectors()
    ra, rm = bitexact.random_vectors(rng, 2000)
    acc = np.concatenate([ea, ra])
    mag = np.concatenate([em, rm])
    assert len(acc) >= 10_000
    got = mcu.survey(fw, acc, mag, cals)
    idx = np.arange(len(acc)) % len(cals)
    arr = [np.array([getattr(c, f) for c in cals], dtype=np.int64)[idx]
           for f in ("acc_m", "acc_b", "mag_m", "mag_b")]
    want = golden.survey_compute(acc, mag, *arr)
    keys = ("g", "b", "inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
    bad, why = _mismatch_report(got, want, keys)
    assert bad == 0, f"{bad} of {len(acc)} surveys differ on the S08: {why}"
    # the run reached the saturation and degenerate paths, not only the easy ones
    flags = got["flags"]
    for bit in (golden.F_ARITH_SATURATED, golden.F_ZERO_GRAVITY, golden.F_ZERO_FIELD,
                golden.F_NEAR_VERTICAL, golden.F_MAG_SATURATED, golden.F_ACC_SATURATED):
        assert (flags & bit).any(), f"flag {bit:#x} never raised"


def _edges32():
    e = [0, 1, -1, 2, -2, 32767, -32768, 32768, -32769, 65535, 65536, -65536, -65537,
         2**29, -(2**29), 2**30, -(2**30), 2**31 - 1, -(2**31), -(2**31) + 1, -(2**31) + 65535,
         0x12345678, -0x12345678]
    return np.array(e, dtype=np.int64)


def test_primitives_bit_exact_on_s08(fw):
    rng = np.random.default_rng(7)
    e = _edges32()
    ex, ey = [a.ravel() for a in np.meshgrid(e, e)]
    n = 1500

    # fx_mul32_q31: all edge pairs (incl. the saturating corner) + random
    a = np.concatenate([ex, rng.integers(*I32, n, endpoint=True)])
    b = np.concatenate([ey, rng.integers(*I32, n, endpoint=True)])
    r, s = mcu.mul32_q31(fw, a, b)
    gr, gs = golden.fx_mul32_q31(a, b)
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()

    # fx_dot3_q31 (the port's assembly): edge triples, zero first operands
    # (skipped by the port), saturating products and sums + random
    t = rng.choice(e, (2000, 6))
    t[:200, 0] = 0
    t[200:400, :3] = 2**31 - 1
    t[200:300, 3:] = 2**31 - 1
    t[300:400, 3:] = -(2**31)
    t[400:450] = -(2**31)
    t = np.concatenate([t, rng.integers(*I32, (n, 6), endpoint=True)])
    r, s = mcu.dot3_q31(fw, t[:, :3], t[:, 3:])
    gr, gs = golden.fx_dot3_q31(t[:, :3], t[:, 3:])
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()
    # ... and of a vector with itself (the port's path for squares)
    r, s = mcu.dot3_q31(fw, t[:, :3])
    gr, gs = golden.fx_dot3_q31(t[:, :3], t[:, :3])
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()

    # att_norm3 (the port's assembly): zero, the rails, every leading-bit
    # position of the largest component (s from -2 to 29), both signs + random
    k = np.arange(32)
    top = np.concatenate([(2**k) - 1, 2**k, 2**k + 1]).clip(0, 2**31 - 1)
    v = rng.integers(-1, 2, (len(top), 3)) * (top[:, None] >> rng.integers(0, 3, (len(top), 3)))
    v[:, 0] = top * np.where(np.arange(len(top)) % 2, 1, -1)
    v = np.concatenate([v, [[0, 0, 0], [-(2**31), 0, 0], [2**31 - 1, -(2**31), 1], [0, 0, -1]],
                        rng.integers(*I32, (n, 3), endpoint=True),
                        rng.integers(-2**20, 2**20, (n, 3))])
    out, sh = mcu.norm3(fw, v)
    gout, gsh = golden.att_norm3(v)
    assert (out != gout).sum() == 0 and (sh != gsh).sum() == 0
    assert set(range(-2, 30)) <= set(sh.tolist())

    # fx_asr32, fx_asr32_rnd, fx_add32_sat, fx_sub32_sat (the port's assembly):
    # every shift count, the rails, ties, both saturations + random
    x = np.concatenate([np.repeat(e, 32), rng.integers(*I32, n, endpoint=True)])
    k = np.concatenate([np.tile(np.arange(32), len(e)), rng.integers(0, 32, n)])
    assert (mcu.asr32(fw, x, k) != golden.fx_asr32(x, k)).sum() == 0
    assert (mcu.asr32(fw, x, k, rnd=True) != golden.fx_asr32_rnd(x, k)).sum() == 0
    a = np.concatenate([ex, rng.integers(*I32, n, endpoint=True)])
    b = np.concatenate([ey, rng.integers(*I32, n, endpoint=True)])
    for sub, fn in ((False, golden.fx_add32_sat), (True, golden.fx_sub32_sat)):
        r, s = mcu.add32_sat(fw, a, b, sub=sub)
        gr, gs = fn(a, b)
        assert (r != gr).sum() == 0 and (s != gs).sum() == 0 and s.any()

    # fx_atan2_q16: axes, diagonals, zero, rails + random
    y = np.concatenate([ey, rng.integers(*I32, n, endpoint=True), [5, -5, 5, -5, 0]])
    x = np.concatenate([ex, rng.integers(*I32, n, endpoint=True), [5, 5, -5, -5, 0]])
    assert (mcu.atan2_q16(fw, y, x) != golden.fx_atan2_q16(y, x)).sum() == 0

    # fx_sqrt_u32_q8 and fx_isqrt_u32: 0, 1, squares and their neighbours,
    # every normalisation shift, the top of the range + random
    sq = np.arange(0, 65536, 97, dtype=np.int64) ** 2
    u = np.concatenate([[0, 1, 2, 3, 2**32 - 1, 2**30, 2**30 - 1, 2**31], sq, sq + 1,
                        np.maximum(sq - 1, 0), 2 ** np.arange(32, dtype=np.int64),
                        rng.integers(0, 2**32, n)])
    assert (mcu.sqrt_u32_q8(fw, u) != golden.fx_sqrt_u32_q8(u)).sum() == 0
    assert (mcu.isqrt_u32(fw, u) != golden.fx_isqrt_u32(u)).sum() == 0

    # fx_div_frac_q20: num >= den, den = 0, the top bit set, ties + random
    den = rng.integers(1, 2**32, n)
    num = (den * rng.uniform(0, 1, n)).astype(np.int64)
    num2 = np.array([0, 1, 5, 2**32 - 2, 2**32 - 1, 7, 2**31, 3], dtype=np.int64)
    den2 = np.array([0, 0, 5, 2**32 - 1, 2**32 - 1, 3, 2**32 - 1, 2**21], dtype=np.int64)
    num = np.concatenate([num, num2])
    den = np.concatenate([den, den2])
    assert (mcu.div_frac_q20(fw, num, den) != golden.fx_div_frac_q20(num, den)).sum() == 0

    # fx_mul16: the int16 rails (the S08 port's assembly helper)
    h = np.array([0, 1, -1, 255, 256, -256, 32767, -32768, 12345, -12345], dtype=np.int64)
    hx, hy = [v.ravel() for v in np.meshgrid(h, h)]
    hx = np.concatenate([hx, rng.integers(-32768, 32768, n)])
    hy = np.concatenate([hy, rng.integers(-32768, 32768, n)])
    assert (mcu.mul16(fw, hx, hy) != hx * hy).sum() == 0


def test_att_and_triad_bit_exact_on_s08(fw):
    rng = np.random.default_rng(9)
    g = rng.integers(-(2**28), 2**28, (300, 3))
    b = rng.integers(-(2**25), 2**25, (300, 3))
    g[:5] = [[0, 0, 0], [0, 0, 1], [2**31 - 1] * 3, [-(2**31)] * 3, [1, -1, 0]]
    got = mcu.att_compute(fw, g, b)
    want = golden.att_compute(g, b)
    bad, why = _mismatch_report(got, want, golden.att_compute(g[:1], b[:1]).keys())
    assert bad == 0, why
    cal = bitexact.random_cals(rng, 6)[1]
    x = rng.integers(-(2**31), 2**31, (300, 3))
    for which, (m, bias) in enumerate(((cal.acc_m, cal.acc_b), (cal.mag_m, cal.mag_b))):
        out, sat = mcu.corr_triad(fw, x, cal, which)
        gout, gsat = golden.corr_triad(x, np.array(m), np.array(bias))
        assert (out != gout).sum() == 0 and (sat != gsat).sum() == 0


def test_cycle_counts_are_exact_and_repeatable(fw):
    acc, mag, fc = mcu.bench_vectors(3)
    recs = mcu._records(b"V", (acc, ">i2"), (mag, ">i4"))
    c1 = mcu.timed(fw, recs, setup=mcu.enc_cal(fc))
    c2 = mcu.timed(fw, recs[::-1], setup=mcu.enc_cal(fc))
    assert c1 == c2[::-1]
    assert all(c > 1000 for c in c1)


def test_stack_use_is_measured_and_repeatable(fw):
    """With --stack-auto the core's locals live on the stack: its depth is
    measured by filling the free stack with a pattern (a figure of the
    bench, not a budget checked here)."""
    acc, mag, fc = mcu.bench_vectors(2)
    recs = mcu._records(b"V", (acc, ">i2"), (mag, ">i4"))
    d = [mcu.stack_bytes(fw, r, setup=mcu.enc_cal(fc)) for r in recs]
    assert d[0] > 16 and d[0] == mcu.stack_bytes(fw, recs[0], setup=mcu.enc_cal(fc))
    z = mcu.stack_bytes(fw, b"Z")
    assert z < d[0]


def test_build_refuses_helper_libraries_with_stack_auto(tmp_path):
    """SDCC's shipped helpers are not reentrant: a --stack-auto image that
    links one (here __mullong, from a 32 x 32 product) is refused."""
    src = tmp_path / "firmware"
    (src / "src").mkdir(parents=True)
    root = mcu.repo_root()
    import shutil
    shutil.copytree(root / "firmware" / "include", src / "include")
    shutil.copytree(root / "firmware" / "port", src / "port")
    for f in mcu.CORE_SOURCES:
        shutil.copy(root / "firmware" / "src" / f, src / "src" / f)
    with open(src / "src" / "survey.c", "a") as fh:
        fh.write("\nint32_t survey_mul_for_test(int32_t a, int32_t b) { return a * b; }\n")
    with pytest.raises(mcu.McuError, match="helper modules"):
        mcu.build(tmp_path / "b", root=tmp_path)


def test_float_baseline_computes_the_same_survey(tmp_path):
    fl = mcu.build(tmp_path, program="float")
    acc, mag, fc = mcu.bench_vectors(12)
    r = mcu.survey_float(fl, acc, mag, fc)
    g = golden.survey_compute(acc, mag, *fc.arrays())
    assert np.abs(r["inc"] - g["inc"] / 65536).max() < 0.01
    assert np.abs((r["azi"] - g["azi"] / 65536 + 180) % 360 - 180).max() < 0.01
    assert np.abs(r["gt"] / (g["gt"] / 2**27) - 1).max() < 1e-4
    assert (r["flags"] == g["flags"]).all()
