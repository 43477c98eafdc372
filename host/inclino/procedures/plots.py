"""Calibration figures (matplotlib, Agg backend, PNG).

* fluxgate_sphere -- Ren 2014 Fig. 9: the fluxgate readings of a calibration
  run before calibration (an offset, stretched ellipsoid) and after (a sphere
  of the field's radius), in 3D, with the radial deviation |b| - F of every
  reading beneath (at the scale of a 50 000 nT sphere a few hundred nT of
  offset is hard to see; the deviation shows it).
* horizontal_circles -- Li 2021 Fig. 2: with one body axis vertical and the
  probe turned about the vertical, the two horizontal components trace a
  circle of radius F cos(dip); before calibration three offset ellipses,
  after it three concentric circles that coincide.  The rows are found from
  the pose columns (any body axis within 3 deg of up or down, >= 6 rows).
* error_maps -- azimuth and inclination error over the acceptance grid
  (inclination or tilt x azimuth), before and after, each with its own
  colour scale.

CLI: `inclino plot --run RUN.csv --cal CAL.json [--accept ACCEPT.json] -o DIR`
(the run gives the sphere and, when it holds circle rotations, the circles;
the accept result of `inclino accept -o` gives the error maps and its
circles); `inclino accept --plot DIR` writes its figures directly.
"""
from __future__ import annotations

import os

import numpy as np

from inclino.plotting import make_dir as _mkdir, pyplot as _plt, save as _save


def _corr(mag, cal):
    from inclino.engines import reference as ref

    if cal is None:
        return np.asarray(mag, float)
    m = cal["mag_m"] if isinstance(cal, dict) else cal.mag_m
    b = cal["mag_b"] if isinstance(cal, dict) else cal.mag_b
    return ref.correct(mag, m, b)


def fluxgate_sphere(mag_raw, cal, field_nT: float, path: str, title: str = "") -> str:
    """mag_raw (n, 3) nT; cal: Calibration or dict of float coefficients."""
    plt = _plt()
    raw = np.asarray(mag_raw, float)
    cor = _corr(raw, cal)
    fig = plt.figure(figsize=(11, 8.5))
    u, v = np.mgrid[0:2 * np.pi:36j, 0:np.pi:18j]
    sx, sy, sz = (field_nT * f for f in (np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)))
    for k, (data, name) in enumerate(((raw, "before calibration (raw)"), (cor, "after calibration"))):
        ax = fig.add_subplot(2, 2, k + 1, projection="3d")
        ax.plot_wireframe(sx, sy, sz, color="0.85", linewidth=0.4)
        ax.scatter(data[:, 0], data[:, 1], data[:, 2], s=8, c="C0" if k == 0 else "C2", depthshade=False)
        c = data.mean(axis=0)
        ax.set_title(f"{name}\ncentre of the readings ({c[0]:.0f}, {c[1]:.0f}, {c[2]:.0f}) nT", fontsize=9)
        ax.set_xlabel("x nT", fontsize=8)
        ax.set_ylabel("y nT", fontsize=8)
        ax.set_zlabel("z nT", fontsize=8)
        ax.tick_params(labelsize=6)
        try:
            ax.set_box_aspect((1, 1, 1))
        except AttributeError:  # pragma: no cover - old matplotlib
            pass
    ax = fig.add_subplot(2, 1, 2)
    dr = np.linalg.norm(raw, axis=1) - field_nT
    dc = np.linalg.norm(cor, axis=1) - field_nT
    ax.plot(dr, "o", ms=3, label=f"before: RMS {np.sqrt(np.mean(dr ** 2)):.0f} nT")
    ax.plot(dc, "o", ms=3, label=f"after: RMS {np.sqrt(np.mean(dc ** 2)):.1f} nT")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("reading")
    ax.set_ylabel(f"|b| - {field_nT:.0f} nT")
    ax.legend(fontsize=8)
    ax.set_title("radial deviation from the sphere of the field's radius", fontsize=9)
    fig.suptitle(title or "Fluxgate before and after calibration (Ren 2014 Fig. 9)")
    fig.tight_layout()
    return _save(fig, path)


def circle_groups(inc, azi, tf, min_rows: int = 6) -> list[tuple[str, np.ndarray, tuple]]:
    """[(label, rows, (i, j) the horizontal axes)] for every body axis that is
    vertical (within 3 deg) in >= min_rows rows spread round the vertical."""
    from inclino.engines import reference as ref

    C = ref.pose_matrix(np.asarray(inc, float), np.asarray(azi, float), np.asarray(tf, float))
    down = C[:, :, 2]
    out = []
    for k, name in enumerate("XYZ"):
        for s, word in ((-1, "up"), (1, "down")):
            rows = np.flatnonzero(s * down[:, k] >= np.cos(np.radians(3.0)))
            if len(rows) < min_rows:
                continue
            # spread: the horizontal direction of another axis must turn round
            j = (k + 1) % 3
            h = np.sort(np.mod(np.degrees(np.arctan2(C[rows, j, 1], C[rows, j, 0])), 360.0))
            if np.max(np.diff(np.append(h, h[0] + 360.0))) > 90.0:
                continue
            out.append((f"{name} {word}", rows, tuple(a for a in range(3) if a != k)))
    return out


def horizontal_circles(mag_raw, inc, azi, tf, cal_before, cal_after, field_nT: float, dip_deg: float | None,
                       path: str, title: str = "") -> str | None:
    """Li 2021 Fig. 2; None when the rows hold no circle rotation."""
    groups = circle_groups(inc, azi, tf)
    if not groups:
        return None
    plt = _plt()
    raw = np.asarray(mag_raw, float)
    fig, axes = plt.subplots(2, 2, figsize=(11, 9.5), gridspec_kw={"height_ratios": [3, 1.4]})
    r = field_nT * np.cos(np.radians(dip_deg)) if dip_deg is not None else None
    for col, (cal, name) in enumerate(((cal_before, "before calibration"), (cal_after, "after calibration"))):
        ax, axd = axes[0, col], axes[1, col]
        data = _corr(raw, cal)
        for n, (label, rows, (i, j)) in enumerate(groups):
            d = data[rows]
            ang = np.degrees(np.arctan2(d[:, j], d[:, i]))
            order = np.argsort(ang)
            d, ang = d[order], ang[order]
            dc = np.vstack([d, d[:1]])
            ax.plot(dc[:, i], dc[:, j], "o-", ms=3, lw=1, color=f"C{n}",
                    label=f"{label}: {'xyz'[i]} vs {'xyz'[j]}")
            rad = np.hypot(d[:, i], d[:, j]) - (r if r is not None else 0.0)
            axd.plot(ang, rad, "o-", ms=3, lw=1, color=f"C{n}", label=label)
        if r is not None:
            t = np.linspace(0, 2 * np.pi, 200)
            ax.plot(r * np.cos(t), r * np.sin(t), "--", color="0.6", lw=0.8, label=f"F cos(dip) = {r:.0f} nT")
        ax.axhline(0, color="0.8", lw=0.6)
        ax.axvline(0, color="0.8", lw=0.6)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("first horizontal component, nT", fontsize=8)
        ax.set_ylabel("second horizontal component, nT", fontsize=8)
        ax.legend(fontsize=7, loc="upper right")
        axd.axhline(0, color="0.6", lw=0.6)
        axd.set_xlabel("angle of the horizontal field in the plane, deg", fontsize=8)
        axd.set_ylabel("radius - F cos(dip), nT" if r is not None else "radius, nT", fontsize=8)
        axd.tick_params(labelsize=7)
    lo = min(a.get_ylim()[0] for a in axes[1])
    hi = max(a.get_ylim()[1] for a in axes[1])
    for a in axes[1]:
        a.set_ylim(lo, hi)
    fig.suptitle(title or "Horizontal circles of the fluxgate, one body axis vertical (Li 2021 Fig. 2)")
    fig.tight_layout()
    return _save(fig, path)


def error_maps(res, path: str) -> str:
    """Azimuth and inclination error over an accept result's grid."""
    plt = _plt()
    incs = []
    for p in res.points:
        if p["set_inc"] not in incs:
            incs.append(p["set_inc"])
    incs = sorted(incs)
    azis = sorted({p["set_azi"] for p in res.points})
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    ylabel = "inclination, deg" if res.grid == "li2021" else "tilt (Ren 2014), deg"
    for col, which in enumerate(("before", "after")):
        for row, what, name in ((0, "azi_err", "azimuth"), (1, "inc_err", "inclination")):
            grid = np.full((len(incs), len(azis)), np.nan)
            for p in res.points:
                v = p[which][what]
                if v is None:
                    continue
                i, j = incs.index(p["set_inc"]), azis.index(p["set_azi"])
                if not np.isfinite(grid[i, j]) or abs(v) > abs(grid[i, j]):
                    grid[i, j] = v
            ax = axes[row, col]
            lim = np.nanmax(np.abs(grid)) if np.isfinite(grid).any() else 1.0
            im = ax.imshow(grid, cmap="RdBu_r", vmin=-lim, vmax=lim, aspect="auto", origin="lower")
            fmt = ".3f" if lim < 0.1 else ".2f"
            for i in range(len(incs)):
                for j in range(len(azis)):
                    if np.isfinite(grid[i, j]):
                        ax.text(j, i, f"{grid[i, j]:{fmt}}", ha="center", va="center", fontsize=6)
            ax.set_xticks(range(len(azis)), [f"{a:g}" for a in azis], fontsize=7)
            ax.set_yticks(range(len(incs)), [f"{a:g}" for a in incs], fontsize=7)
            ax.set_xlabel("azimuth, deg", fontsize=8)
            ax.set_ylabel(ylabel, fontsize=8)
            s = res.stats[which]
            rms, mx = s[f"{what[:3]}_rms_deg"], s[f"{what[:3]}_max_deg"]
            ax.set_title(f"{name} error, {which} (RMS {rms:.3f}, max {mx:.3f} deg)" if rms is not None
                         else f"{name} error, {which}", fontsize=9)
            fig.colorbar(im, ax=ax, label="deg")
    fig.suptitle(f"Acceptance grid {res.grid}, probe {res.probe_serial}: before = {res.before[:40]}, "
                 f"after = {res.after[:40]}", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def accept_figures(res, out_dir: str) -> list[str]:
    _mkdir(out_dir)
    paths = [error_maps(res, os.path.join(out_dir, f"errors_{res.grid}.png"))]
    if res.circles:
        c = {k: np.array([row[k] for row in res.circles], float) for k in res.circles[0]}
        mag = np.stack([c["mx_nT"], c["my_nT"], c["mz_nT"]], -1)
        F = res.world.get("field_nT") or float(np.median(np.linalg.norm(_corr(mag, res.after_cal), axis=1)))
        p = horizontal_circles(mag, c["inc_deg"], c["azi_deg"], c["tf_deg"], res.before_cal, res.after_cal, F,
                               res.world.get("dip_deg"), os.path.join(out_dir, "circles.png"))
        if p:
            paths.append(p)
    return paths


def run_figures(ds, cal, out_dir: str, cal_before=None) -> list[str]:
    """The sphere (and the circles when the run has circle rotations) of a
    calibration run `ds` (RawDataset) with its calibration."""
    from inclino.calib import common

    _mkdir(out_dir)
    w = common.world_of(ds)
    paths = [fluxgate_sphere(ds.mag, cal, w["field_nT"], os.path.join(out_dir, "fluxgate_sphere.png"))]
    if ds.has_pose:
        p = horizontal_circles(ds.mag, ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"],
                               cal_before, cal, w["field_nT"], w["dip_deg"],
                               os.path.join(out_dir, "run_circles.png"),
                               "Horizontal circles in the calibration run (Li 2021 Fig. 2 layout)")
        if p:
            paths.append(p)
    return paths
