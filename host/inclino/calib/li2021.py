"""Li Zhong, Li Yang, Zhao Yanlai, "Application of the twelve-position
calibration method for the borehole inclinometer", Drilling Engineering
2021, 48(5):76-82.

Error model, eq. (3)/(4), per triad (H raw, M true body-frame reading):

    H_x = K_x (M_x + e_yx M_y + e_zx M_z) + B_x
    H_y = K_y (e_xy M_x + M_y + e_zy M_z) + B_y
    H_z = K_z (e_xz M_x + e_yz M_y + M_z) + B_z

i.e. H = diag(K) (I + E) M + B with I + E = [[1, e_yx, e_zx],
[e_xy, 1, e_zy], [e_xz, e_yz, 1]].  The twelve positions of Table 1 (in our
frame: docs/conventions.md section 6) give the closed form eq. (5)-(16):
positions 1-4 (X down twice, X up twice) give B_x, K_x, e_xy, e_xz;
positions 5-8 (Y vertical) B_y, K_y, e_yx, e_yz; 9-12 (Z vertical) B_z, K_z,
e_zx, e_zy.  V (M_d for the fluxgate, g_d for the accelerometer) is the
vertical component of the field; only the unit of the result depends on it.
Eq. (14) is printed with "H_z" for "H_z12" (a typo; read as H_z12).

Inverse coefficients, eq. (17)-(32): M = [A_i B_i C_i] H + D_i, which is
inv(diag(K)(I + E)) and D = -inv(...) B.  Our firmware's correction
corrected = M (raw - b) takes M = [A B C] and b = B (Table 2's bias).

Table 2's installation-error block is read as in inclino.model.effects
(row X = (e_xy, e_xz), row Y = (e_yx, e_yz), row Z = (e_zx, e_zy)), the
reading under which Table 3 follows from Table 2 (docs/calibration.md).
"""
from __future__ import annotations

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset
from inclino.errors import DataError

from . import common

# Table 1 in our frame (docs/conventions.md section 6): a pose per position.
POSITIONS = {
    1: (90, 0, 180), 2: (90, 180, 180), 3: (90, 0, 0), 4: (90, 180, 0),
    5: (90, 0, 90), 6: (90, 180, 90), 7: (90, 180, 270), 8: (90, 0, 270),
    9: (0, 0, 0), 10: (0, 0, 180), 11: (180, 0, 0), 12: (180, 0, 180),
}
# Li 2021 Table 2 and Table 3, as printed (biases and D in A/D counts).
TABLE2 = {
    "mag": {"B": [-188.795, 129.94, -314.095], "K": [0.9514, 0.9716, 0.9067],
            "e": [[0.0312, 0.0306], [-0.0076, 0.0399], [0.0062, -0.0566]]},
    "acc": {"B": [-17.5863, -46.3725, -6.8975], "K": [0.9998, 0.9977, 0.9977],
            "e": [[0.0046, -0.0013], [-0.0074, -0.0606], [0.0019, 0.0585]]},
}
TABLE3 = {
    "mag": {"ABC": [[1.051, 0.0081, -0.0063], [-0.0345, 1.0266, 0.0625], [-0.0308, -0.0412, 1.1006]],
            "D": [195, -120, 345]},
    "acc": {"ABC": [[1.0002, 0.0072, -0.0023], [-0.0047, 0.9987, -0.0584], [0.001, 0.0605, 0.9988]],
            "D": [18, 46, 10]},
}


def position_rows(ds: RawDataset, tol_deg: float = 5.0) -> dict:
    """Rows of the dataset at each Table 1 position (the body axes within
    tol_deg of the position's), keyed 1..12."""
    C = common.pose_matrices(ds)
    out = {}
    for p, pose in POSITIONS.items():
        Cp = ref.pose_matrix(*pose)
        cosang = (np.trace(np.swapaxes(C, -1, -2) @ Cp, axis1=-2, axis2=-1) - 1.0) / 2.0
        out[p] = np.flatnonzero(cosang >= np.cos(np.radians(tol_deg)))
    return out


def closed_form(H: np.ndarray, V: float):
    """Eq. (5)-(16).  H (12, 3): the triad's mean reading at positions 1-12
    (row p-1).  Returns K (3,), B (3,), e (3, 2) in Table 2's layout."""
    h = np.asarray(H, float)
    def pair(a, b, c, d, axis):
        return h[a - 1, axis] + h[b - 1, axis] - h[c - 1, axis] - h[d - 1, axis]
    B = np.array([h[0:4, 0].mean(), h[4:8, 1].mean(), h[8:12, 2].mean()])
    K = np.array([pair(1, 2, 3, 4, 0), pair(5, 6, 7, 8, 1), pair(9, 10, 11, 12, 2)]) / (4 * V)
    if np.any(np.abs(K) < 1e-6):
        raise DataError("li2021: a scale factor came out zero: are the twelve positions right?")
    exy = pair(1, 2, 3, 4, 1) / (4 * V * K[1])
    exz = pair(1, 2, 3, 4, 2) / (4 * V * K[2])
    eyx = pair(5, 6, 7, 8, 0) / (4 * V * K[0])
    eyz = pair(5, 6, 7, 8, 2) / (4 * V * K[2])
    ezx = pair(9, 10, 11, 12, 0) / (4 * V * K[0])
    ezy = pair(9, 10, 11, 12, 1) / (4 * V * K[1])
    return K, B, np.array([[exy, exz], [eyx, eyz], [ezx, ezy]])


def forward_matrix(K, e) -> np.ndarray:
    """diag(K) (I + E) of eq. (3)/(4) from Table 2's layout of e."""
    (exy, exz), (eyx, eyz), (ezx, ezy) = np.asarray(e, float)
    IE = np.array([[1.0, eyx, ezx], [exy, 1.0, ezy], [exz, eyz, 1.0]])
    return np.asarray(K, float)[:, None] * IE


def inverse_coefficients(K, B, e, form: str = "corrected"):
    """Eq. (17)-(32): ([A_i B_i C_i] rows (3, 3), D (3,)).

    form="printed" evaluates the formulas exactly as printed.  Two of them
    are misprinted: eq. (21) B_1 = (e_yx - e_zx e_zy)/(K_y T) should read
    (e_yx - e_zx e_yz)/(K_y T), and eq. (23)'s 2nd and 3rd brackets,
    (e_zx e_yz - e_yx e_zx) and (e_yx e_zy - e_zx e_xy), should read
    (e_zx e_yz - e_yx) and (e_yx e_zy - e_zx) (docs/calibration.md).
    form="corrected" fixes those two; form="matrix" is the matrix inverse
    (identical to "corrected" to rounding)."""
    K = np.asarray(K, float)
    B = np.asarray(B, float)
    if form == "matrix":
        inv = np.linalg.inv(forward_matrix(K, e))
        return inv, -inv @ B
    if form not in ("printed", "corrected"):
        raise ValueError(f"unknown form {form!r}")
    printed = form == "printed"
    (exy, exz), (eyx, eyz), (ezx, ezy) = np.asarray(e, float)
    Kx, Ky, Kz = K
    Bx, By, Bz = B
    T = eyx * exy + ezx * exz + ezy * eyz - eyx * ezy * exz - ezx * exy * eyz - 1  # (32)
    A1 = (ezy * eyz - 1) / (Kx * T)  # (20)
    B1 = ((eyx - ezx * ezy) if printed else (eyx - ezx * eyz)) / (Ky * T)  # (21)
    C1 = (ezx - eyx * ezy) / (Kz * T)  # (22)
    if printed:  # (23) as printed
        D1 = ((1 - ezy * eyz) * Bx / Kx + (ezx * eyz - eyx * ezx) * By / Ky
              + (eyx * ezy - ezx * exy) * Bz / Kz) / T
    else:
        D1 = ((1 - ezy * eyz) * Bx / Kx + (ezx * eyz - eyx) * By / Ky + (eyx * ezy - ezx) * Bz / Kz) / T
    A2 = (exy - ezy * exz) / (Kx * T)  # (24)
    B2 = (ezx * exz - 1) / (Ky * T)  # (25)
    C2 = (ezy - ezx * exy) / (Kz * T)  # (26)
    D2 = ((ezy * exz - exy) * Bx / Kx + (1 - ezx * exz) * By / Ky + (ezx * exy - ezy) * Bz / Kz) / T  # (27)
    A3 = (exz - exy * eyz) / (Kx * T)  # (28)
    B3 = (eyz - eyx * exz) / (Ky * T)  # (29)
    C3 = (eyx * exy - 1) / (Kz * T)  # (30)
    D3 = ((exy * eyz - exz) * Bx / Kx + (eyx * exz - eyz) * By / Ky + (1 - eyx * exy) * Bz / Kz) / T  # (31)
    return np.array([[A1, B1, C1], [A2, B2, C2], [A3, B3, C3]]), np.array([D1, D2, D3])


def table3_from_table2(form: str = "corrected", samples: int = 20000, seed: int = 0) -> dict:
    """Table 3 recomputed from Table 2 (per kind: ABC (3, 3), D (3,)), and
    the range each coefficient can take when Table 2's inputs vary within
    their printed rounding (half a unit of the last printed digit), by
    seeded uniform sampling of that box: ABC_lo/ABC_hi, D_lo/D_hi."""
    rng = np.random.default_rng(seed)
    out = {}
    for kind, t2 in TABLE2.items():
        K, B, e = (np.asarray(t2[k], float) for k in ("K", "B", "e"))
        ABC, D = inverse_coefficients(K, B, e, form)
        half = lambda vals, digits: 0.5 * 10.0 ** -np.asarray(digits, float)
        hK = half(K, [4, 4, 4])
        hB = half(B, [_decimals(v) for v in t2["B"]])
        he = np.full((3, 2), 0.5e-4)
        sa, sd = [], []
        for _ in range(samples // 1000):
            u = lambda h, n: (rng.uniform(-1, 1, (n,) + np.shape(h)) * h)
            n = 1000
            Ks, Bs, es = K + u(hK, n), B + u(hB, n), e + u(he, n)
            for i in range(n):
                a, d = inverse_coefficients(Ks[i], Bs[i], es[i], form)
                sa.append(a)
                sd.append(d)
        sa, sd = np.array(sa), np.array(sd)
        out[kind] = {"ABC": ABC, "D": D, "ABC_lo": sa.min(0), "ABC_hi": sa.max(0),
                     "D_lo": sd.min(0), "D_hi": sd.max(0)}
    return out


def _decimals(v) -> int:
    s = repr(float(v))
    return len(s.split(".")[1]) if "." in s else 0


def fit(ds: RawDataset, tol_deg: float = 5.0, **_):
    """Twelve-position closed form for both triads; needs the pose columns
    and every Table 1 position at least once (several readings at one
    position are averaged)."""
    common.need_poses(ds, "li2021")
    w = common.world_of(ds)
    dip = common.require_dip(ds, "li2021")
    rows = position_rows(ds, tol_deg)
    missing = [p for p, r in rows.items() if len(r) == 0]
    if missing:
        raise DataError(f"li2021 needs all twelve positions of Li 2021 Table 1; missing position(s) "
                        f"{', '.join(map(str, missing))} (docs/conventions.md section 6 gives their poses)")
    Ha = np.array([ds.acc[rows[p]].mean(axis=0) for p in range(1, 13)])
    Hm = np.array([ds.mag[rows[p]].mean(axis=0) for p in range(1, 13)])
    gd = w["gravity_g"]
    Md = w["field_nT"] * np.sin(np.radians(dip))
    if abs(Md) < 1e-3 * w["field_nT"]:
        raise DataError("li2021 uses the vertical field component, which is zero at this dip")
    out = {}
    for kind, H, V in (("acc", Ha, gd), ("mag", Hm, Md)):
        K, B, e = closed_form(H, V)
        ABC, D = inverse_coefficients(K, B, e, "corrected")
        out[kind] = {"K": K.tolist(), "B": B.tolist(), "e": e.tolist(), "ABC": ABC.tolist(), "D": D.tolist()}
    cal = common.make_cal(out["acc"]["ABC"], out["acc"]["B"], out["mag"]["ABC"], out["mag"]["B"], "li2021", ds)
    used = np.unique(np.concatenate([rows[p] for p in range(1, 13)]))
    return cal, {"rows_used": used, "paper_parameters": out,
                 "notes": [f"positions matched within {tol_deg:g} deg; V = g_d = {gd:g} g, M_d = {Md:.1f} nT"]}
