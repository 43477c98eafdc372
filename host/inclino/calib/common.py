"""Shared pieces of the calibration methods: the world the dataset was taken
in, the turntable poses, the dataset hash, the parameter layout.

Model direction.  The firmware applies corrected = M @ (raw - b) per triad.
The papers fit the forward form raw = A @ true + c (Li eq. 3/4:
A = diag(K)(I + E), c = B; Guo eq. 1/3: row i of A = SF_i * direction
cosines, c_i = SF_i * Bias_i; Ren eq. 8 and 11 are already in the correcting
direction).  The two are converted exactly by M = inv(A), b = c
(forward_to_correction / correction_to_forward).
"""
from __future__ import annotations

import hashlib
import json

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import ACC_B_LIMIT, M_LIMIT, MAG_B_LIMIT, Calibration
from inclino.formats.dataset import POSE_COLS, RawDataset
from inclino.errors import CalibrationError, DataError

PARAM_NAMES = ([f"acc_m{i}{j}" for i in range(3) for j in range(3)] + [f"acc_b{i}" for i in range(3)]
               + [f"mag_m{i}{j}" for i in range(3) for j in range(3)] + [f"mag_b{i}" for i in range(3)])
DEFAULT_FIELD_NT = 50000.0
SIGMA_ACC = 1.5e-4  # g, ADIS16210-class noise of one reading: the project's probe's, assumed when the data declare none
SIGMA_MAG = 5.0  # nT, the probe's fluxgate's


def assumed_noise(ds: RawDataset, sigma_acc: float | None = None, sigma_mag: float | None = None,
                  declared: bool = True) -> dict:
    """The noise of one reading a fit assumes, per triad: the one given
    (an option), else (declared) the one the dataset header declares
    (acc_noise_g, mag_noise_nT: `inclino import` writes the sensor
    description's noise), else the project's probe's (SIGMA_ACC,
    SIGMA_MAG).  {"acc_g", "mag_nT", "acc_from", "mag_from"}, the sources
    "given", "declared" or "nominal".  A fit of one triad at a time scales
    its covariance by s^2 against it, so the declared noise changes only
    what s^2 is against; the joint fit with poses weighs both triads
    against each other by it, and takes the nominal (declared=False)."""
    out = {}
    for t, unit, given, nominal in (("acc", "g", sigma_acc, SIGMA_ACC), ("mag", "nT", sigma_mag, SIGMA_MAG)):
        said = ds.meta.get(f"{t}_noise_{unit}") if declared else None
        if given:
            v, src = float(given), "given"
        elif said:
            v, src = float(said), "declared"
        else:
            v, src = nominal, "nominal"
        out[f"{t}_{unit}"], out[f"{t}_from"] = v, src
    return out


def world_of(ds: RawDataset, field_nT: float | None = None) -> dict:
    """Field total (nT), dip and declination (deg), gravity (g) from the
    dataset header; the field total (field_of, unless given) defaults to the
    sphere's radius or the median raw norm when the header lacks it (it only
    sets the unit of the corrected field)."""
    m = ds.meta
    return {"field_nT": field_of(ds)[0] if field_nT is None else float(field_nT), "dip_deg": m.get("dip_deg"),
            "declination_deg": float(m.get("declination_deg", 0.0)),
            "gravity_g": float(m.get("gravity_g", 1.0))}


def field_of(ds: RawDataset) -> tuple:
    """(field total in nT, where it came from): the header's field_nT, else
    the radius of the sphere the raw readings lie on (offsets do not move
    it), else their median |b|; 50 000 nT without a magnetometer."""
    F = ds.meta.get("field_nT")
    if F is not None:
        return float(F), "the header's field_nT"
    if not ds.has_mag:
        return DEFAULT_FIELD_NT, "50000 nT (no magnetometer)"
    from .ellipsoid import sphere

    sph = sphere(ds.mag) if len(ds) >= 10 else None
    F = sph[1] if sph is not None else float(np.median(np.linalg.norm(ds.mag, axis=1)))
    return float(F or DEFAULT_FIELD_NT), (("the radius of the sphere the raw readings lie on" if sph is not None else
                                           "the raw readings' median |b|") + ": no field_nT in the header")


def need_poses(ds: RawDataset, method: str) -> None:
    if not ds.has_pose:
        missing = [c for c in POSE_COLS if c not in ds.columns]
        raise DataError(f"{method} needs the turntable pose columns; missing: {', '.join(missing)}")


def pose_matrices(ds: RawDataset) -> np.ndarray:
    return ref.pose_matrix(ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"])


def true_vectors(ds: RawDataset, dip_deg: float, field_nT: float, declination_deg=0.0, gravity_g=1.0):
    """Body-frame gravity (g) and field (nT) at the dataset's poses."""
    return ref.body_vectors(ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"],
                            field_nT, dip_deg, declination_deg, gravity_g)


def require_dip(ds: RawDataset, method: str) -> float:
    d = ds.meta.get("dip_deg")
    if d is None:
        raise DataError(f"{method} needs the field's dip: add a '# dip_deg=...' header line")
    return float(d)


def forward_to_correction(A, c):
    """raw = A @ true + c  ->  (M, b) with true = M @ (raw - b)."""
    A = np.asarray(A, float)
    if not np.all(np.isfinite(A)) or abs(np.linalg.det(A)) < 1e-12 * max(1.0, np.abs(A).max()) ** 3:
        raise CalibrationError("the fitted sensor matrix is singular")
    return np.linalg.inv(A), np.asarray(c, float).copy()


def correction_to_forward(M, b):
    return np.linalg.inv(np.asarray(M, float)), np.asarray(b, float).copy()


def refuse_out_of_range(ds, cal) -> None:
    """A fitted triad the probe's calibration format cannot hold (an offset
    beyond calfile.ACC_B_LIMIT g or MAG_B_LIMIT nT, a matrix element beyond
    M_LIMIT), refused in the user's terms (CalibrationError, exit 3, as
    docs/cli.md has every calibration out of the firmware's range; nothing
    written).  Calibration.check said "acc_b beyond +-2" of a tag's log
    imported with its lsb declared 4.9x too large: a name of the file's,
    no cause, no fix.  The readings' size the fit implies (the nominal over
    the matrix's mean singular value) tells a scale or unit declared wrong
    from a triad whose zero is far off."""
    for triad, name, unit, blim in (("acc", "accelerometer", "g", ACC_B_LIMIT),
                                    ("mag", "magnetometer", "nT", MAG_B_LIMIT)):
        if not getattr(ds, f"has_{triad}"):
            continue
        M = np.asarray(getattr(cal, f"{triad}_m"), float)
        b = np.asarray(getattr(cal, f"{triad}_b"), float)
        if not (M.shape == (3, 3) and b.shape == (3,) and np.all(np.isfinite(M)) and np.all(np.isfinite(b))):
            continue  # Calibration.check names it
        over_b, over_m = bool(np.abs(b).max() >= blim), bool(np.abs(M).max() >= M_LIMIT)
        if not (over_b or over_m):
            continue
        size = 1.0 / float(np.mean(np.linalg.svd(M, compute_uv=False)))  # the readings over the nominal
        xyz = ", ".join(f"{v:+.4g}" for v in b)
        what = (f"the {name}'s offset the fit needs, ({xyz}) {unit} (x, y, z), is beyond the +-{blim:g} {unit} "
                f"the probe's calibration format holds" if over_b else
                f"the {name}'s scale correction the fit needs, {np.abs(M).max():.3g}x, is beyond the {M_LIMIT:g}x "
                f"the probe's calibration format holds")
        key = f"[{name}] unit, lsb and zero in the sensor description"
        if not 0.8 <= size <= 1.25:
            cause = (f"the readings are {size:.3g}x the {'gravity' if triad == 'acc' else 'field'} they should read: "
                     f"a scale or unit declared wrong; check the {key} and import again")
        else:
            cause = (f"the readings' scale is right ({size:.3g}x) and their zero far off: a zero declared wrong, or a "
                     f"triad far off its range; check the {key}, or the part")
        raise CalibrationError(f"{what}: {cause}; nothing written")


def make_cal(acc_m, acc_b, mag_m, mag_b, method, ds: RawDataset) -> Calibration:
    for name, v in (("acc_m", acc_m), ("acc_b", acc_b), ("mag_m", mag_m), ("mag_b", mag_b)):
        if not np.all(np.isfinite(np.asarray(v, float))):
            raise CalibrationError(f"the fit gave non-finite {name} (singular or degenerate data)")
    cal = Calibration(acc_m=np.asarray(acc_m, float).tolist(), acc_b=np.asarray(acc_b, float).tolist(),
                      mag_m=np.asarray(mag_m, float).tolist(), mag_b=np.asarray(mag_b, float).tolist(),
                      method=method, probe_serial=str(ds.meta.get("probe_serial", "")))
    refuse_out_of_range(ds, cal)
    cal.check()
    return cal


def cal_vector(cal: Calibration) -> np.ndarray:
    """The 24 coefficients in PARAM_NAMES order."""
    return np.concatenate([np.ravel(cal.acc_m), cal.acc_b, np.ravel(cal.mag_m), cal.mag_b]).astype(float)


def cal_from_vector(v, method="", serial="") -> Calibration:
    v = np.asarray(v, float)
    return Calibration(acc_m=v[0:9].reshape(3, 3).tolist(), acc_b=v[9:12].tolist(),
                       mag_m=v[12:21].reshape(3, 3).tolist(), mag_b=v[21:24].tolist(),
                       method=method, probe_serial=serial)


def dataset_hash(ds: RawDataset) -> dict:
    """SHA-256 of the dataset's content (column names and float64 values in
    file order, then the header as sorted JSON): the same data give the same
    hash however the CSV was formatted."""
    h = hashlib.sha256()
    for c in sorted(ds.columns):
        h.update(c.encode())
        h.update(np.ascontiguousarray(ds.columns[c], dtype="<f8").tobytes())
    h.update(json.dumps(ds.meta, sort_keys=True, default=str).encode())
    return {"sha256": h.hexdigest(), "of": "dataset content (columns as float64, header)", "rows": len(ds)}


def file_hash(path: str, ds: RawDataset) -> dict:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):  # bounded memory on a long run
            h.update(block)
    digest = h.hexdigest()
    return {"sha256": digest, "of": "file bytes", "rows": len(ds)}


def subset(ds: RawDataset, rows) -> RawDataset:
    rows = np.asarray(rows)
    return RawDataset({k: v[rows] for k, v in ds.columns.items()}, dict(ds.meta))


def body_axis_groups(C: np.ndarray, tol_deg: float = 3.0):
    """For each body axis k (0 x, 1 y, 2 z) and sense s (+1 down, -1 up),
    the rows whose axis k points within tol_deg of straight down/up."""
    down = C[:, :, 2]  # down component of each body axis, (n, 3)
    c = np.cos(np.radians(tol_deg))
    return {(k, s): np.flatnonzero(s * down[:, k] >= c) for k in range(3) for s in (1, -1)}


def fill_bias_jacobian(x, T) -> None:
    """Rows of the Jacobian from (M, c) to (M, b) for both triads, b = M^-1 c,
    written into T in place: x holds M (9, row-major) and c (3) of the
    accelerometer at 0..11 and of the fluxgate at 12..23, as the pose fits
    lay them out. The M rows are the identity, db = M^-1 (dc - dM b)."""
    for off in (0, 12):
        M = np.asarray(x[off:off + 9], float).reshape(3, 3)
        Minv = np.linalg.inv(M)
        b = Minv @ np.asarray(x[off + 9:off + 12], float)
        T[off:off + 9, off:off + 9] = np.eye(9)
        for i in range(3):
            for j in range(3):
                E = np.zeros((3, 3))
                E[i, j] = 1.0
                T[off + 9:off + 12, off + 3 * i + j] = -Minv @ (E @ b)
        T[off + 9:off + 12, off + 9:off + 12] = Minv
