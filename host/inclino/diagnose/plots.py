"""PNG plots of a diagnosis (matplotlib, Agg backend: no display needed).

* one file per kept effect, `<name>_<sensor>_<axis>.png`: the residual of
  the axis the effect shows most on, against the effect's winning regressor
  (temperature, the axis's signal, or the effect's own signature), before
  (the model without this effect) and after (with it);
* `baseline.png`: each axis's baseline residual against the regressor
  family that explains most of it (the residual study); of a pose-free
  diagnosis (no poses, or one triad: posefree.py), each invariant's
  residual (|g|, |b|, the dip) against time or the reading order, the
  baseline's and, with effects named, the final model's."""
from __future__ import annotations

import os

import numpy as np

from inclino import plotting


def write(result, outdir: str) -> list:
    if not result.plot_data:
        raise ValueError("the diagnosis was run without keep_plot_data=True")
    plt = plotting.pyplot()
    plotting.make_dir(outdir, "the plot directory")
    written = []

    def save(fig, name):
        written.append(plotting.save(fig, os.path.join(outdir, name)))

    for e, ent in zip(result.effects, result.plot_data["effects"]):
        fig, axs = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
        x = np.asarray(ent["x"], float)
        for ax, key, title in ((axs[0], "before", "before (without this effect)"),
                               (axs[1], "after", "after (with it)")):
            y = np.asarray(ent[key], float)
            ax.plot(x, y, ".", ms=3, alpha=0.6)
            ax.axhline(0.0, color="k", lw=0.7)
            ax.set_title(f"{title}: RMS {np.sqrt(np.mean(y ** 2)):.3g}", fontsize=9)
            ax.set_xlabel(ent["xlabel"], fontsize=8)
            ax.grid(alpha=0.3)
        axs[0].set_ylabel(ent["ylabel"], fontsize=8)
        fig.suptitle(f"{ent['title']} = {e.estimate:.4g} +- {e.stderr:.2g} {e.units}", fontsize=10)
        fig.tight_layout()
        save(fig, ent["file"])

    if result.plot_data.get("mode") == "invariants":
        save(_invariants_figure(plt, result.plot_data["baseline"]), "baseline.png")
        return written
    fig, axs = plt.subplots(2, 3, figsize=(13, 7))
    for ax, ent in zip(axs.ravel(), result.plot_data["baseline"]):
        ax.plot(np.asarray(ent["x"], float), np.asarray(ent["y"], float), ".", ms=3, alpha=0.6)
        ax.axhline(0.0, color="k", lw=0.7)
        p = ent["p"]
        ax.set_title(f"{ent['channel']}: strongest {ent['family'] or '-'}"
                     + (f" (p = {p:.2g})" if p is not None else ""), fontsize=9)
        ax.set_xlabel(ent["xlabel"], fontsize=8)
        ax.set_ylabel(ent["ylabel"], fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle("baseline residuals (12-parameter model per triad) against the residual study's strongest regressor",
                 fontsize=10)
    fig.tight_layout()
    save(fig, "baseline.png")
    return written


def _invariants_figure(plt, ents):
    """The pose-free baseline: one panel per invariant, its residual against
    time or the reading order (and the final model's, effects named)."""
    fig, axs = plt.subplots(1, len(ents), figsize=(4.5 * len(ents), 4), squeeze=False)
    for ax, ent in zip(axs[0], ents):
        x, y = np.asarray(ent["x"], float), np.asarray(ent["y"], float)
        ax.plot(x, y, ".", ms=3, alpha=0.6, label=f"baseline: RMS {np.sqrt(np.mean(y ** 2)):.3g}")
        if ent.get("after") is not None:
            a = np.asarray(ent["after"], float)
            ax.plot(x, a, ".", ms=3, alpha=0.6, label=f"with the effects named: RMS {np.sqrt(np.mean(a ** 2)):.3g}")
        ax.axhline(0.0, color="k", lw=0.7)
        ax.set_title(ent["channel"], fontsize=9)
        ax.set_xlabel(ent["xlabel"], fontsize=8)
        ax.set_ylabel(ent["ylabel"], fontsize=8)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    # one invariant's figure is 4.5 in wide: the title wraps there instead of running off both edges
    title = "pose-free baseline residuals (a symmetric 3x3 and an offset per triad fitted to the invariants)"
    fig.suptitle(title.replace(" (", "\n(") if len(ents) == 1 else title, fontsize=10)
    fig.tight_layout()
    return fig


def write_paper(rep, outdir: str) -> list:
    """The papers' check tables before and after, measured against the simulation (diagnose --paper --plot)."""
    plt = plotting.pyplot()
    plotting.make_dir(outdir, "the plot directory")
    paths = []

    def save(fig, name):
        paths.append(plotting.save(fig, os.path.join(outdir, name)))

    if rep.paper == "li2021":
        for state in ("before", "after"):
            s = rep.series[state]
            fig, axs = plt.subplots(1, 2, figsize=(12, 4.5))
            m = s["kind"] == "azi"
            for a in np.unique(s["A"][m]):
                k = m & (s["A"] == a)
                ln, = axs[0].plot(s["I"][k], s["measured"][k], "o-", ms=4, label=f"A = {a:g}")
                other = s["predicted"] if state == "before" else s["fitted"]
                axs[0].plot(s["I"][k], other[k], "--", color=ln.get_color())
            axs[0].set_xlabel("inclination (deg)")
            axs[0].set_ylabel("azimuth error (deg)")
            axs[0].set_title(f"Table 5 {state}: measured (o) and "
                             + ("Table 2 simulation, toolface 0 (--)" if state == "before" else "extended model (--)"),
                             fontsize=9)
            axs[0].legend(fontsize=7)
            k = s["kind"] == "inc"
            axs[1].plot(s["I"][k], s["measured"][k], "o-", label="measured")
            other = s["predicted"] if state == "before" else s["fitted"]
            axs[1].plot(s["I"][k], other[k], "s--", label="simulation" if state == "before" else "extended model")
            axs[1].set_xlabel("inclination (deg)")
            axs[1].set_ylabel("inclination error (deg)")
            axs[1].set_title(f"Table 4 {state}", fontsize=9)
            axs[1].legend(fontsize=7)
            for ax in axs:
                ax.grid(alpha=0.3)
            fig.tight_layout()
            save(fig, f"li2021_{state}.png")
    else:
        fig, axs = plt.subplots(2, 2, figsize=(11, 7))
        for ax, key, xl in ((axs[0, 0], "t1_before", "signed tilt (deg)"), (axs[0, 1], "t1_after", "signed tilt (deg)"),
                            (axs[1, 0], "t2_before", "azimuth (deg)"), (axs[1, 1], "t2_after", "azimuth (deg)")):
            s = rep.series[key]
            o = np.argsort(s["x"])
            ax.plot(np.asarray(s["x"])[o], np.asarray(s["measured"])[o], "o-", label="measured")
            ax.plot(np.asarray(s["x"])[o], np.asarray(s["fitted"])[o], "s--", label="kept effects")
            ax.set_xlabel(xl)
            ax.set_ylabel("error (deg)")
            ax.set_title(key.replace("t1", "Table 1").replace("t2", "Table 2").replace("_", " "), fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.tight_layout()
        save(fig, "ren2014.png")
    return paths
