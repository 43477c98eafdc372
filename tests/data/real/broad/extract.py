"""Rebuild the BROAD tables here from the published trial files.

    python extract.py DATA_MAT_DIR

DATA_MAT_DIR holds BROAD's `data_mat/*.mat` (https://github.com/dlaidig/broad,
commit 7e2f8189bb4a3ac91eae32c69b6bc87f08a6e2ad).  For each trial below it
checks the file's SHA-256, keeps every 20th sample at which the optical
reference is defined, and writes the IMU readings as published (m/s^2, rad/s,
uT), the optical quaternion as published (sensor to east-north-up, w x y z)
and the pose it is in the body frame of docs/conventions.md (body = the IMU's
own x, y, z; world north-east-down), to 9 significant digits.
"""
import hashlib
import sys
from pathlib import Path

import numpy as np
import scipy.io

TRIALS = {
    "05_undisturbed_slow_rotation_with_breaks_B":
        "70957bc3e0755c1952115f2b28855b638ff9ee714c75618dd3a89603e4f3a2f2",
    "02_undisturbed_slow_rotation_B":
        "2ab69f86aab5fcc018399068baaabc725bb4b53862aefbef70eaf0256da1930a",
}
STEP = 20
ENU_TO_NED = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])


def quat_to_matrix(q):
    """Rotation matrices (n, 3, 3) of unit quaternions w x y z (Hamilton)."""
    q = q / np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def poses(q):
    """(inc, azi, tf) in degrees: C = body <- NED = (ENU_TO_NED R)^T, with
    C = Rz(T) Ry(I) Rz(A) (docs/conventions.md section 2)."""
    c = np.transpose(ENU_TO_NED @ quat_to_matrix(q), (0, 2, 1))
    inc = np.degrees(np.arccos(np.clip(c[:, 2, 2], -1, 1)))
    azi = np.degrees(np.arctan2(c[:, 2, 1], c[:, 2, 0])) % 360
    tf = np.degrees(np.arctan2(c[:, 1, 2], -c[:, 0, 2])) % 360
    return inc, azi, tf


def main(src):
    for name, digest in TRIALS.items():
        path = Path(src) / f"{name}.mat"
        got = hashlib.sha256(path.read_bytes()).hexdigest()
        if got != digest:
            raise SystemExit(f"{path}: sha256 {got}, not the published {digest}")
        d = scipy.io.loadmat(path)
        fs = float(d["sampling_rate"][0, 0])
        ok = np.all(np.isfinite(d["opt_quat"]), axis=1)
        keep = np.flatnonzero(ok)[::STEP]
        t = keep / fs
        acc, gyr, mag, q = (d[k][keep] for k in ("imu_acc", "imu_gyr", "imu_mag", "opt_quat"))
        inc, azi, tf = poses(q)
        mov = d["movement"].ravel()[keep]
        cols = ["sample", "t_s", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z",
                "mag_x", "mag_y", "mag_z", "q_w", "q_x", "q_y", "q_z", "movement",
                "inc_deg", "azi_deg", "tf_deg"]
        with open(f"{name[:2]}.csv", "w", encoding="utf-8") as f:
            f.write(",".join(cols) + "\n")
            for i in range(len(keep)):
                vals = [str(keep[i]), f"{t[i]:.6f}"]
                vals += [f"{v:.9g}" for v in (*acc[i], *gyr[i], *mag[i], *q[i])]
                vals += [str(int(mov[i]))] + [f"{v:.6f}" for v in (inc[i], azi[i], tf[i])]
                f.write(",".join(vals) + "\n")


if __name__ == "__main__":
    main(sys.argv[1])
