"""PNG plots of a diagnosis (matplotlib, Agg backend: no display needed).

* one file per kept effect, `<name>_<sensor>_<axis>.png`: the residual of
  the axis the effect shows most on, against the effect's winning regressor
  (temperature, the axis's signal, or the effect's own signature), before
  (the model without this effect) and after (with it);
* `baseline.png`: each axis's baseline residual against the regressor
  family that explains most of it (the residual study)."""
from __future__ import annotations

import os

import numpy as np

from inclino.errors import DataError


def write(result, outdir: str) -> list:
    if not result.plot_data:
        raise ValueError("the diagnosis was run without keep_plot_data=True")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        os.makedirs(outdir, exist_ok=True)
    except OSError as e:
        raise DataError(f"cannot create the plot directory {outdir}: {e.strerror}")
    written = []

    def save(fig, name):
        path = os.path.join(outdir, name)
        from inclino.formats import safeio

        try:
            safeio.save_figure(fig, path, dpi=110)
        finally:
            plt.close(fig)
        written.append(path)

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
