"""Pins docs/conventions.md: frames, pose matrix, sensor signs, output
formulas, Li 2021 Table 1, and how the papers' formulas map onto ours.

Expected values come from the printed definitions, the papers' tables and
hand geometry, never from the code under test."""
from __future__ import annotations

import math

import numpy as np
import pytest

from inclino.engines import firmware as core, reference as ref

Q16 = 65536.0
NEAR_VERTICAL = 0x0001  # ATT_F_NEAR_VERTICAL, firmware/include/inclino/attitude.h

# World directions (NED) of Li 2021's direction words.
DIR = {
    "北": np.array([1.0, 0.0, 0.0]),   # north
    "南": np.array([-1.0, 0.0, 0.0]),  # south
    "东": np.array([0.0, 1.0, 0.0]),   # east
    "西": np.array([0.0, -1.0, 0.0]),  # west
    "地": np.array([0.0, 0.0, 1.0]),   # down (ground)
    "天": np.array([0.0, 0.0, -1.0]),  # up (sky)
}
N, E, D = DIR["北"], DIR["东"], DIR["地"]

# Li 2021 Table 1, transcribed: position, X, Y, Z, (Mx, My, Mz), (Gx, Gy, Gz).
LI_TABLE1 = [
    (1, "地", "西", "北", ("Md", "-Me", "Mn"), ("gd", "-ge", "gn")),
    (2, "地", "东", "南", ("Md", "Me", "-Mn"), ("gd", "ge", "-gn")),
    (3, "天", "东", "北", ("-Md", "Me", "Mn"), ("-gd", "ge", "gn")),
    (4, "天", "西", "南", ("-Md", "-Me", "-Mn"), ("-gd", "-ge", "-gn")),
    (5, "东", "地", "北", ("Me", "Md", "Mn"), ("ge", "gd", "gn")),
    (6, "西", "地", "南", ("-Me", "Md", "-Mn"), ("-ge", "gd", "-gn")),
    (7, "东", "天", "南", ("Me", "-Md", "-Mn"), ("ge", "-gd", "-gn")),
    (8, "西", "天", "北", ("-Me", "-Md", "Mn"), ("-ge", "-gd", "gn")),
    (9, "北", "东", "地", ("Mn", "Me", "Md"), ("gn", "ge", "gd")),
    (10, "南", "西", "地", ("-Mn", "-Me", "Md"), ("-gn", "-ge", "gd")),
    (11, "南", "东", "天", ("-Mn", "Me", "-Md"), ("-gn", "ge", "-gd")),
    (12, "北", "西", "天", ("Mn", "-Me", "-Md"), ("gn", "-ge", "-gd")),
]

# The poses of Table 1 worked out by hand (docs/conventions.md section 6);
# for I = 0 the defined sum T + A, for I = 180 the defined difference T - A.
LI_HAND = {1: (90, 0, 180), 2: (90, 180, 180), 3: (90, 0, 0), 4: (90, 180, 0),
           5: (90, 0, 90), 6: (90, 180, 90), 7: (90, 180, 270), 8: (90, 0, 270),
           9: (0, "T+A", 0), 10: (0, "T+A", 180), 11: (180, "T-A", 0), 12: (180, "T-A", 180)}

FIELD_NT = 50000.0
DIP_CHENGDU = 45.1


def _wrap(a):
    return float(np.mod(a, 360.0))


def _adiff(a, b):
    """Smallest signed difference a - b in degrees (independent of reference.angle_diff)."""
    return (np.asarray(a, float) - np.asarray(b, float) + 180.0) % 360.0 - 180.0


def _expr(s, comps):
    sign = -1.0 if s.startswith("-") else 1.0
    return sign * comps[s.lstrip("-")]


def _pose_from_axes(x, y, z):
    """(I, A, T) from the body axes' NED directions by geometry alone: I from
    straight down to the tool axis, A clockwise from north seen from above,
    T from the high side to body x, clockwise looking down-hole.  Returns
    (I, None, T + A) at I = 0 and (I, None, T - A) at I = 180."""
    inc = math.degrees(math.acos(max(-1.0, min(1.0, float(z @ D)))))
    if inc < 1e-9:
        return inc, None, _wrap(math.degrees(math.atan2(x @ E, x @ N)))
    if inc > 180 - 1e-9:
        # I = 180: body x = N (-cos(T - A)) + E sin(T - A) (printed Ry(180) Rz(A), Rz(T))
        return inc, None, _wrap(math.degrees(math.atan2(x @ E, -(x @ N))))
    azi = _wrap(math.degrees(math.atan2(z @ E, z @ N)))
    up = -D
    high = up - (up @ z) * z
    high /= np.linalg.norm(high)
    right = np.cross(z, high)  # looking down-hole along z, clockwise from high side
    tf = _wrap(math.degrees(math.atan2(x @ right, x @ high)))
    return inc, azi, tf


def _hand_rz(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def _hand_ry(i):
    c, s = math.cos(math.radians(i)), math.sin(math.radians(i))
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _ren_c(theta, psi, t):
    """Ren 2014 eq. (1), transcribed element by element."""
    cps, sps = math.cos(math.radians(psi)), math.sin(math.radians(psi))
    cth, sth = math.cos(math.radians(theta)), math.sin(math.radians(theta))
    ct, st = math.cos(math.radians(t)), math.sin(math.radians(t))
    return np.array([
        [cps * cth * ct - sps * st, sps * cth * ct + cps * st, -sth * ct],
        [-cps * cth * st - sps * ct, -sps * cth * st + cps * ct, sth * st],
        [cps * sth, sps * sth, cth],
    ])


def _random_poses(n, seed, imin=1.0, imax=179.0):
    rng = np.random.default_rng(seed)
    inc = np.degrees(np.arccos(rng.uniform(math.cos(math.radians(imax)),
                                           math.cos(math.radians(imin)), n)))
    return inc, rng.uniform(0, 360, n), rng.uniform(0, 360, n), rng.uniform(-85, 85, n)


def _truth(inc, azi, tf, dip, field=FIELD_NT, dec=0.0):
    """Body readings by the documented physics: g = C [0,0,1], b = C F[...]."""
    c = ref.pose_matrix(inc, azi, tf)
    d, e = np.radians(dip), np.radians(dec)
    f = field * np.stack([np.cos(d) * np.cos(e), np.cos(d) * np.sin(e), np.sin(d)], -1)
    return c[..., :, 2], np.einsum("...ij,...j->...i", c, f)


def _firmware(g_g, b_nt):
    """Firmware attitude (identity calibration) from ideal counts."""
    acc = np.clip(np.round(np.atleast_2d(g_g) * 16384.0), -32768, 32767).astype(np.int64)
    mag = np.round(np.atleast_2d(b_nt)).astype(np.int64)
    return core.survey(acc * 64, mag * 64)  # whole counts as Q6 readings


# ---------------------------------------------------------------------------
# Rotation matrices and pose matrix
ANGLES = [0.0, 17.0, 90.0, 135.5, 180.0, 263.0, 359.0]


@pytest.mark.parametrize("a", ANGLES)
def test_rz_ry_match_printed_definitions(a):
    r = math.radians(a)
    c, s = math.cos(r), math.sin(r)
    z = ref.rz(a)
    y = ref.ry(a)
    assert z[0, 0] == pytest.approx(c, abs=1e-15) and z[0, 1] == pytest.approx(s, abs=1e-15)
    assert z[1, 0] == pytest.approx(-s, abs=1e-15) and z[1, 1] == pytest.approx(c, abs=1e-15)
    assert (z[0, 2], z[1, 2], z[2, 0], z[2, 1], z[2, 2]) == (0, 0, 0, 0, 1)
    assert y[0, 0] == pytest.approx(c, abs=1e-15) and y[0, 2] == pytest.approx(-s, abs=1e-15)
    assert y[2, 0] == pytest.approx(s, abs=1e-15) and y[2, 2] == pytest.approx(c, abs=1e-15)
    assert (y[0, 1], y[1, 0], y[1, 1], y[1, 2], y[2, 1]) == (0, 0, 1, 0, 0)


@pytest.mark.parametrize("inc,azi,tf", [(0, 0, 0), (30, 45, 60), (90, 0, 180), (123, 250, 310),
                                        (180, 10, 20), (5, 359, 1)])
def test_pose_matrix_is_rz_ry_rz_and_expanded_form(inc, azi, tf):
    c = ref.pose_matrix(inc, azi, tf)
    np.testing.assert_allclose(c, _hand_rz(tf) @ _hand_ry(inc) @ _hand_rz(azi), atol=1e-15)
    ci, si = math.cos(math.radians(inc)), math.sin(math.radians(inc))
    ca, sa = math.cos(math.radians(azi)), math.sin(math.radians(azi))
    ct, st = math.cos(math.radians(tf)), math.sin(math.radians(tf))
    expanded = np.array([[ct * ci * ca - st * sa, ct * ci * sa + st * ca, -ct * si],
                         [-st * ci * ca - ct * sa, -st * ci * sa + ct * ca, st * si],
                         [si * ca, si * sa, ci]])
    np.testing.assert_allclose(c, expanded, atol=1e-15)


def test_pose_matrix_is_proper_rotation():
    inc, azi, tf, _ = _random_poses(1000, 1, 0.0, 180.0)
    c = ref.pose_matrix(inc, azi, tf)
    eye = np.broadcast_to(np.eye(3), c.shape)
    np.testing.assert_allclose(c @ np.swapaxes(c, -1, -2), eye, atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(c), 1.0, atol=1e-14)


def test_zero_pose_is_ned():
    np.testing.assert_array_equal(ref.pose_matrix(0.0, 0.0, 0.0), np.eye(3))
    g, b = ref.body_vectors(0.0, 0.0, 0.0, field_nT=FIELD_NT, dip_deg=60.0)
    np.testing.assert_allclose(g, [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(b, [FIELD_NT * 0.5, 0, FIELD_NT * math.sqrt(3) / 2], atol=1e-9)


def test_geometric_pose_derivation_agrees_with_pose_matrix():
    """The hand geometry used for Table 1 and the pose matrix agree on random poses."""
    inc, azi, tf, _ = _random_poses(200, 2)
    c = ref.pose_matrix(inc, azi, tf)
    for k in range(len(inc)):
        i, a, t = _pose_from_axes(c[k, 0], c[k, 1], c[k, 2])
        assert i == pytest.approx(inc[k], abs=1e-9)
        assert _adiff(a, azi[k]) == pytest.approx(0, abs=1e-9)
        assert _adiff(t, tf[k]) == pytest.approx(0, abs=1e-9)


# ---------------------------------------------------------------------------
# Li 2021 Table 1
@pytest.mark.parametrize("row", LI_TABLE1, ids=lambda r: f"pos{r[0]}")
def test_li2021_table1_position(row):
    pos, xw, yw, zw, mcols, gcols = row
    x, y, z = DIR[xw], DIR[yw], DIR[zw]
    assert np.array_equal(np.cross(x, y), z), "table orientation must be right-handed"

    inc, azi, comb = _pose_from_axes(x, y, z)
    hand = LI_HAND[pos]
    assert inc == pytest.approx(hand[0], abs=1e-9)
    if azi is None:
        assert _adiff(comb, hand[2]) == pytest.approx(0, abs=1e-9)
        # only T + A (I = 0) or T - A (I = 180) is fixed: any split works
        splits = [(a, comb - a if inc < 90 else comb + a) for a in (0.0, 37.0, 200.0)]
    else:
        assert (azi, comb) == pytest.approx(hand[1:], abs=1e-9)
        splits = [(azi, comb)]

    expected_axes = np.stack([x, y, z])
    for a, t in splits:
        c = ref.pose_matrix(inc, a, t)
        np.testing.assert_allclose(c, expected_axes, atol=1e-15)
        # component columns: body reading of an arbitrary world vector (n, e, d)
        vn, ve, vd = 0.31, -0.47, 0.83
        comps_m = {"Mn": vn, "Me": ve, "Md": vd}
        comps_g = {"gn": vn, "ge": ve, "gd": vd}
        body = c @ np.array([vn, ve, vd])
        np.testing.assert_allclose(body, [_expr(s, comps_m) for s in mcols], atol=1e-15)
        np.testing.assert_allclose(body, [_expr(s, comps_g) for s in gcols], atol=1e-15)

    # the physical field and gravity of the Chengdu lab (declination 3 deg so Me != 0)
    a, t = splits[0]
    g, b = ref.body_vectors(inc, a, t, field_nT=FIELD_NT, dip_deg=DIP_CHENGDU,
                            declination_deg=3.0)
    dip, dec = math.radians(DIP_CHENGDU), math.radians(3.0)
    mf = {"Mn": FIELD_NT * math.cos(dip) * math.cos(dec),
          "Me": FIELD_NT * math.cos(dip) * math.sin(dec), "Md": FIELD_NT * math.sin(dip)}
    np.testing.assert_allclose(b, [_expr(s, mf) for s in mcols], atol=1e-9)
    np.testing.assert_allclose(g, [_expr(s, {"gn": 0.0, "ge": 0.0, "gd": 1.0}) for s in gcols],
                               atol=1e-15)

    # attitude from the table's readings (magnetic north: declination 0)
    mf0 = {"Mn": FIELD_NT * math.cos(dip), "Me": 0.0, "Md": FIELD_NT * math.sin(dip)}
    b0 = np.array([_expr(s, mf0) for s in mcols])
    g0 = np.array([_expr(s, {"gn": 0.0, "ge": 0.0, "gd": 1.0}) for s in gcols])
    r = ref.attitude(g0, b0)
    fw = _firmware(g0, b0)
    fwd = {k: fw[k][0] / Q16 for k in ("inc", "azi", "gtf", "mtf", "dip")}
    for res, tol in ((r, 1e-9), (fwd, 2e-3)):
        assert res["inc"] == pytest.approx(hand[0], abs=tol)
        assert float(res["dip"]) == pytest.approx(DIP_CHENGDU, abs=max(tol, 5e-3))
        if azi is None:
            # MTF carries the defined combination: T + A at I = 0, T - A + 180 at I = 180
            want_mtf = hand[2] if inc < 90 else hand[2] + 180.0
            assert _adiff(res["mtf"], want_mtf) == pytest.approx(0, abs=tol)
        else:
            assert _adiff(res["azi"], hand[1]) == pytest.approx(0, abs=tol)
            assert _adiff(res["gtf"], hand[2]) == pytest.approx(0, abs=tol)
    near_vertical = bool(fw["flags"][0] & NEAR_VERTICAL)
    assert near_vertical == (azi is None)


def test_li2021_position1_is_i90_a0_t180():
    # X down, Y west, Z north
    g = np.array([1.0, 0.0, 0.0])
    b = FIELD_NT * np.array([math.sin(math.radians(DIP_CHENGDU)), 0.0,
                             math.cos(math.radians(DIP_CHENGDU))])
    fw = _firmware(g, b)
    assert fw["inc"][0] == pytest.approx(90 * Q16, abs=2)
    assert _adiff(fw["azi"][0] / Q16, 0) == pytest.approx(0, abs=1e-3)
    assert fw["gtf"][0] == pytest.approx(180 * Q16, abs=2)
    np.testing.assert_allclose(ref.pose_matrix(90, 0, 180) @ np.array([0, 0, 1.0]), g, atol=1e-15)


# ---------------------------------------------------------------------------
# Units of the firmware outputs
def test_firmware_output_formats():
    # 1 g on body z (16384 counts), 50 000 nT horizontal north field at I = 0
    fw = core.survey(np.array([[0, 0, 16384]]) * 64, np.array([[50000, 0, 0]]) * 64)  # Q6 readings
    assert fw["gt"][0] == pytest.approx(2**27, rel=2e-6)         # Q27 g
    assert fw["bt"][0] == pytest.approx(50000 * 256, rel=2e-6)   # Q8 nT
    assert fw["g"][0, 2] == pytest.approx(2**27, abs=32)
    assert fw["b"][0, 0] == pytest.approx(50000 * 256, abs=32)
    assert fw["inc"][0] == 0 and fw["dip"][0] == pytest.approx(0, abs=2)
    fw = core.survey(np.array([[0, 16384, 0]]) * 64, np.array([[0, 0, 40000]]) * 64)
    assert fw["inc"][0] == pytest.approx(90 * Q16, abs=2)         # Q16 degrees
    assert fw["gtf"][0] == pytest.approx(90 * Q16, abs=2)


# ---------------------------------------------------------------------------
# Sign pins
def test_gravity_reads_plus_one_g_on_a_down_axis():
    # body x pointing down: I = 90, T = 180 (x on the low side)
    g, _ = ref.body_vectors(90.0, 0.0, 180.0)
    np.testing.assert_allclose(g, [1.0, 0.0, 0.0], atol=1e-15)
    g, _ = ref.body_vectors(0.0, 0.0, 0.0)
    np.testing.assert_allclose(g, [0.0, 0.0, 1.0], atol=1e-15)
    g, _ = ref.body_vectors(180.0, 0.0, 0.0)
    np.testing.assert_allclose(g, [0.0, 0.0, -1.0], atol=1e-15)


def _readings_from_axes(x, y, z, dip=DIP_CHENGDU):
    f = FIELD_NT * np.array([math.cos(math.radians(dip)), 0.0, math.sin(math.radians(dip))])
    axes = np.stack([x, y, z])
    return axes @ D, axes @ f


def test_azimuth_clockwise_from_north():
    # tool axis east, horizontal, x on the high side: y = z x x = south
    z, x = E, -D
    y = np.cross(z, x)
    np.testing.assert_allclose(y, -N)
    g, b = _readings_from_axes(x, y, z)
    r = ref.attitude(g, b)
    assert (r["inc"], r["azi"], r["gtf"]) == pytest.approx((90, 90, 0), abs=1e-9)
    fw = _firmware(g, b)
    assert fw["azi"][0] == pytest.approx(90 * Q16, abs=20)
    # 30 deg east of north, inclined 40 deg: A = 30 (clockwise seen from above)
    z = math.sin(math.radians(40)) * (math.cos(math.radians(30)) * N + math.sin(math.radians(30)) * E) \
        + math.cos(math.radians(40)) * D
    x = -D - (-D @ z) * z
    x /= np.linalg.norm(x)
    g, b = _readings_from_axes(x, np.cross(z, x), z)
    r = ref.attitude(g, b)
    assert (r["inc"], r["azi"], r["gtf"]) == pytest.approx((40, 30, 0), abs=1e-9)


def test_toolface_90_means_x_right_of_high_side():
    # hole heading north, horizontal: right of the high side (looking down-hole) is east
    z, x = N, E
    y = np.cross(z, x)
    np.testing.assert_allclose(y, D)  # y on the low side: gravity all on +y
    g, b = _readings_from_axes(x, y, z)
    np.testing.assert_allclose(g, [0, 1, 0], atol=1e-15)
    r = ref.attitude(g, b)
    assert r["gtf"] == pytest.approx(90, abs=1e-9)
    np.testing.assert_allclose(ref.pose_matrix(90, 0, 90), np.stack([x, y, z]), atol=1e-15)
    fw = _firmware(g, b)
    assert fw["gtf"][0] == pytest.approx(90 * Q16, abs=2)
    # T = 0: x on the high side reads -sin I
    g, _ = ref.body_vectors(30.0, 123.0, 0.0)
    assert g[0] == pytest.approx(-0.5, abs=1e-15) and g[1] == pytest.approx(0, abs=1e-15)


def test_dip_positive_in_northern_hemisphere():
    inc, azi, tf, _ = _random_poses(500, 3, 0.0, 180.0)
    for dip in (DIP_CHENGDU, 70.0, -30.0):
        g, b = _truth(inc, azi, tf, dip)
        r = ref.attitude(g, b)
        np.testing.assert_allclose(r["dip"], dip, atol=1e-9)
        # against the documented asin form
        want = np.degrees(np.arcsin(np.sum(g * b, -1) / (np.linalg.norm(g, axis=-1)
                                                        * np.linalg.norm(b, axis=-1))))
        np.testing.assert_allclose(r["dip"], want, atol=1e-6)
    g, b = _truth(inc[:50], azi[:50], tf[:50], DIP_CHENGDU)
    fw = _firmware(g, b)
    assert np.all(fw["dip"] > 0)
    np.testing.assert_allclose(fw["dip"] / Q16, DIP_CHENGDU, atol=0.01)


def test_mtf_equals_gtf_plus_azimuth_near_vertical():
    rng = np.random.default_rng(4)
    n = 2000
    azi, tf = rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    # exactly vertical: MTF = T + A (I = 0), T - A + 180 (I = 180)
    g, b = _truth(np.zeros(n), azi, tf, DIP_CHENGDU)
    np.testing.assert_allclose(_adiff(ref.attitude(g, b)["mtf"], tf + azi), 0, atol=1e-9)
    fw = _firmware(g, b)
    np.testing.assert_allclose(_adiff(fw["mtf"] / Q16, tf + azi), 0, atol=0.01)
    assert np.all(fw["flags"] & NEAR_VERTICAL)
    g, b = _truth(np.full(n, 180.0), azi, tf, DIP_CHENGDU)
    np.testing.assert_allclose(_adiff(ref.attitude(g, b)["mtf"], tf - azi + 180), 0, atol=1e-9)
    # near vertical: |MTF - (GTF + A)| <= ~ I tan|dip|, shrinking with I
    for inc in (0.5, 0.1, 0.01):
        for dip in (DIP_CHENGDU, 70.0):
            g, b = _truth(np.full(n, inc), azi, tf, dip)
            r = ref.attitude(g, b)
            d = np.abs(_adiff(r["mtf"], r["gtf"] + r["azi"]))
            assert d.max() <= 1.01 * inc * math.tan(math.radians(dip))
    # and it is a real difference away from vertical (the pin can fail)
    g, b = _truth(np.full(n, 30.0), azi, tf, DIP_CHENGDU)
    r = ref.attitude(g, b)
    assert np.abs(_adiff(r["mtf"], r["gtf"] + r["azi"])).max() > 5


def test_mtf_definition():
    # MTF = atan2(-by, bx): angle from the field's cross-section projection to x
    inc, azi, tf, dip = _random_poses(1000, 5)
    g, b = _truth(inc, azi, tf, dip)
    r = ref.attitude(g, b)
    np.testing.assert_allclose(_adiff(r["mtf"], np.degrees(np.arctan2(-b[:, 1], b[:, 0]))), 0,
                               atol=1e-9)


def test_near_vertical_threshold_is_half_a_degree():
    for inc, flagged in ((0.0, True), (0.45, True), (0.55, False), (90.0, False),
                         (179.45, False), (179.55, True), (180.0, True)):
        g, b = _truth(np.array([inc]), np.array([40.0]), np.array([70.0]), DIP_CHENGDU)
        fw = _firmware(g, b)
        assert bool(fw["flags"][0] & NEAR_VERTICAL) == flagged, inc


def test_outputs_recover_random_poses():
    inc, azi, tf, dip = _random_poses(5000, 6)
    g, b = _truth(inc, azi, tf, dip)
    r = ref.attitude(3.0 * g, b)  # the angles do not depend on the scale of g
    np.testing.assert_allclose(r["inc"], inc, atol=1e-9)
    np.testing.assert_allclose(_adiff(r["azi"], azi), 0, atol=1e-8)
    np.testing.assert_allclose(_adiff(r["gtf"], tf), 0, atol=1e-9)
    assert np.all((r["azi"] >= 0) & (r["azi"] < 360) & (r["gtf"] >= 0) & (r["gtf"] < 360))
    sel = slice(0, 300)
    fw = _firmware(g[sel], b[sel])
    np.testing.assert_allclose(fw["inc"] / Q16, inc[sel], atol=0.01)
    ok = (inc[sel] > 5) & (inc[sel] < 175)
    np.testing.assert_allclose(_adiff(fw["azi"] / Q16, azi[sel])[ok], 0, atol=0.02)
    np.testing.assert_allclose(_adiff(fw["gtf"] / Q16, tf[sel])[ok], 0, atol=0.02)


# ---------------------------------------------------------------------------
# The papers' formulas against ours
def test_li2021_eq2_literal_is_ours_plus_180():
    inc, azi, tf, dip = _random_poses(20000, 7)
    g, b = _truth(inc, azi, tf, dip)
    li = ref.li2021_azimuth(g, b)
    np.testing.assert_allclose(_adiff(li, azi + 180.0), 0, atol=1e-8)
    # the printed ratio (one-argument arctan) equals ours modulo 180
    ax, ay, az = g.T
    hx, hy, hz = b.T
    ratio = (np.linalg.norm(g, axis=-1) * (hx * ay - hy * ax)) / \
        (az * (hx * ax + hy * ay) - hz * (ax * ax + ay * ay))
    ok = np.abs(np.cos(np.radians(azi))) > 1e-3
    np.testing.assert_allclose(_adiff(2 * np.degrees(np.arctan(ratio[ok])), 2 * azi[ok]), 0,
                               atol=1e-7)


def test_li2021_eq1_is_inclination_folded_to_90():
    inc, azi, tf, dip = _random_poses(5000, 8, 0.5, 179.5)
    g, _ = _truth(inc, azi, tf, dip)
    ax, ay, az = g.T
    theta = np.degrees(np.arctan(np.sqrt((ax * ax + ay * ay) / (az * az))))
    np.testing.assert_allclose(theta, np.minimum(inc, 180.0 - inc), atol=1e-9)


def test_ren2014_eq7_literal_is_ours_plus_90():
    inc, azi, tf, dip = _random_poses(20000, 9)
    g, b = _truth(inc, azi, tf, dip)
    ren = ref.ren2014_azimuth(g, b)
    np.testing.assert_allclose(_adiff(ren, azi + 90.0), 0, atol=1e-8)
    # Ren's eq. (7) uses normalised readings but is scale invariant
    np.testing.assert_allclose(_adiff(ref.ren2014_azimuth(7 * g, b / 3), ren), 0, atol=1e-9)


def test_ren2014_eq1_is_our_matrix_and_frame_is_wnd():
    inc, azi, tf, dip = _random_poses(50, 10, 0.0, 180.0)
    p = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # NED -> (W, N, D)
    for i, a, t, d in zip(inc, azi, tf, dip):
        np.testing.assert_allclose(_ren_c(i, a, t), ref.pose_matrix(i, a, t), atol=1e-14)
        np.testing.assert_allclose(_ren_c(i, a + 90.0, t) @ p, ref.pose_matrix(i, a, t),
                                   atol=1e-14)
        # eq. (3), (6) in Ren's (x0, y0, z0) = (W, N, D): our body readings
        c = _ren_c(i, a + 90.0, t)
        g_ren = c @ np.array([0, 0, 1.0])
        m_ren = c @ np.array([0, math.cos(math.radians(d)), math.sin(math.radians(d))])
        g, b = _truth(np.array(i), np.array(a), np.array(t), np.array(d), field=1.0)
        np.testing.assert_allclose(g_ren, g, atol=1e-14)
        np.testing.assert_allclose(m_ren, b, atol=1e-14)


def test_ren2014_eq4_and_eq5():
    inc, azi, tf, dip = _random_poses(5000, 11, 0.5, 179.5)
    g, _ = _truth(inc, azi, tf, dip)
    ax, ay, az = g.T
    # eq. (4): with atan2 = ours; one-argument arctan gives I - 180 above 90
    np.testing.assert_allclose(np.degrees(np.arctan2(np.hypot(ax, ay), az)), inc, atol=1e-9)
    one_arg = np.degrees(np.arctan(np.hypot(ax, ay) / az))
    np.testing.assert_allclose(one_arg, np.where(inc <= 90, inc, inc - 180.0), atol=1e-9)
    # eq. (5): T = -arctan(Ay/Ax) is our T modulo 180
    ok = np.abs(ax) > 1e-6
    t5 = -np.degrees(np.arctan(ay[ok] / ax[ok]))
    np.testing.assert_allclose(_adiff(2 * t5, 2 * tf[ok]), 0, atol=1e-6)
    # four-quadrant readings of its minus sign are 180 off; atan2(Ay, -Ax) is ours
    np.testing.assert_allclose(_adiff(-np.degrees(np.arctan2(ay, ax)), tf + 180), 0, atol=1e-9)
    np.testing.assert_allclose(_adiff(np.degrees(np.arctan2(-ay, ax)), tf + 180), 0, atol=1e-9)
    np.testing.assert_allclose(_adiff(np.degrees(np.arctan2(ay, -ax)), tf), 0, atol=1e-9)


def test_guo2009_eq7_eq10():
    inc, azi, tf, dip = _random_poses(1000, 12, 0.0, 180.0)
    g, b = _truth(inc, azi, tf, dip, field=54.0)
    d, a, r, phi = (np.radians(v) for v in (inc, azi, tf, dip))
    bh, bv = 54.0 * np.cos(phi), 54.0 * np.sin(phi)
    guo_b = np.stack([
        bh * (np.cos(r) * np.cos(a) * np.cos(d) - np.sin(r) * np.sin(a)) - bv * np.cos(r) * np.sin(d),
        bh * (-np.sin(r) * np.cos(a) * np.cos(d) - np.cos(r) * np.sin(a)) + bv * np.sin(r) * np.sin(d),
        bh * np.cos(a) * np.sin(d) + bv * np.cos(d)], -1)
    np.testing.assert_allclose(guo_b, b, atol=1e-12)
    guo_g = np.stack([np.cos(r) * np.sin(d), -np.sin(r) * np.sin(d), -np.cos(d)], -1)
    np.testing.assert_allclose(guo_g, -g, atol=1e-15)
