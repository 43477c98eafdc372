"""Figure of a well path and its 1-sigma / 2-sigma horizontal ellipses
(matplotlib, Agg): plan view and vertical section, from the rows of a
trajectory listing (inclino trajectory --uncertainty)."""
from __future__ import annotations

import math

import numpy as np


MAX_ELLIPSES = 200  # stations whose ellipses are drawn (evenly spread): more cannot be told apart


def plot(rows, path: str, truth=None, title: str = "", scale: float | None = None) -> str:
    """rows: trajectory CSV rows (dicts); truth: optional (tvd, north, east)
    arrays of the known path.  Ellipses are drawn magnified (`scale`, by
    default so the largest 2-sigma ellipse spans ~1/8 of the plan) and the
    factor is printed in the legend."""
    from matplotlib.patches import Ellipse

    from inclino import plotting

    plt = plotting.pyplot()

    if hasattr(rows, "column"):  # a wellpath.Trajectory: its columns as they are
        f, has_ell = rows.column, "ell_major_m" in rows.data
    else:
        f = lambda k: np.array([float(r[k]) if r.get(k, "") != "" else np.nan for r in rows])  # noqa: E731
        has_ell = all("ell_major_m" in r for r in rows)
    n, e, tvd, md = f("north_m"), f("east_m"), f("tvd_m"), f("md_m")
    if truth is not None and has_ell:
        fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(16, 5.2), gridspec_kw={"width_ratios": [1.1, 1.1, 1]})
    else:
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 5.2))
        ax3 = None
    ax1.plot(e, n, "-o", ms=2.5, lw=1, color="C0", label="inclino trajectory")
    span = max(np.ptp(n), np.ptp(e), 1.0)
    if has_ell:
        a, b, az = f("ell_major_m"), f("ell_minor_m"), f("ell_azi_deg")
        amax = np.nanmax(a) if np.any(np.isfinite(a)) else 0
        k = scale if scale is not None else (span / 8 / (2 * amax) if amax > 0 else 1.0)
        for i in np.unique(np.linspace(0, len(md) - 1, min(len(md), MAX_ELLIPSES)).astype(int)):
            if not (np.isfinite(a[i]) and a[i] > 0):
                continue
            for m, ls in ((1, "-"), (2, "--")):
                # ellipse azimuth from north, clockwise; matplotlib angle from +x (east), counter-clockwise
                ax1.add_patch(Ellipse((e[i], n[i]), 2 * m * k * a[i], 2 * m * k * b[i], angle=90.0 - az[i],
                                      fill=False, ls=ls, lw=0.7, color="C1" if m == 1 else "C3"))
        ax1.plot([], [], "-", color="C1", lw=0.7, label=f"1-sigma ellipse x {k:.0f}")
        ax1.plot([], [], "--", color="C3", lw=0.7, label=f"2-sigma ellipse x {k:.0f}")
        st = f("sigma_tvd_m")
        ax2.fill_between(np.hypot(n, e), tvd - 2 * k * st, tvd + 2 * k * st, color="C3", alpha=0.2,
                         label=f"TVD 2-sigma x {k:.0f}")
    if truth is not None:
        t_tvd, t_n, t_e = truth
        ax1.plot(t_e, t_n, "k+", ms=6, label="known path (stations)")
        ax2.plot(np.hypot(t_n, t_e), t_tvd, "k+", ms=6, label="known path (stations)")
    ax1.set_xlabel("east of the first station, m")
    ax1.set_ylabel("north, m")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.set_title("plan view (true north)")
    ax1.legend(fontsize=8, loc="upper left")
    ax1.grid(alpha=0.3)
    ax2.plot(np.hypot(n, e), tvd, "-o", ms=2.5, lw=1, color="C0", label="inclino trajectory")
    ax2.invert_yaxis()
    ax2.set_xlabel("horizontal displacement, m")
    ax2.set_ylabel("TVD, m")
    ax2.set_title("vertical section")
    ax2.legend(fontsize=8, loc="upper right")
    ax2.grid(alpha=0.3)
    if ax3 is not None:
        t_tvd, t_n, t_e = truth
        dn, de = n - t_n, e - t_e
        cnn, cne, cee = f("cov_nn"), f("cov_ne"), f("cov_ee")
        d = np.full(len(md), np.nan)
        for i in range(len(md)):
            c = np.array([[cnn[i], cne[i]], [cne[i], cee[i]]])
            if np.all(np.isfinite(c)) and np.linalg.det(c) > 0:
                v = np.array([dn[i], de[i]])
                d[i] = math.sqrt(float(v @ np.linalg.solve(c, v)))
        ax3.plot(md, np.hypot(dn, de) * 100, "-o", ms=2.5, color="C0", label="horizontal error, cm")
        ax3.plot(md, a * 100, "-", color="C1", label="1-sigma semi-major, cm")
        ax3.plot(md, 2 * a * 100, "--", color="C3", label="2-sigma semi-major, cm")
        ax3b = ax3.twinx()
        ax3b.plot(md, d, ":", color="k", label="Mahalanobis distance (right)")
        ax3b.axhline(2.0, color="C3", lw=0.6, ls=":")
        ax3b.set_ylabel("error / ellipse (Mahalanobis distance)")
        ax3b.set_ylim(0, max(3.0, np.nanmax(d) * 1.1 if np.any(np.isfinite(d)) else 3.0))
        ax3.set_xlabel("measured depth, m")
        ax3.set_ylabel("cm")
        ax3.set_title("position error against the known path")
        h1, l1 = ax3.get_legend_handles_labels()
        h2, l2 = ax3b.get_legend_handles_labels()
        ax3.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
        ax3.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return plotting.save(fig, path)
