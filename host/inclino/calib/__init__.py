"""Calibration fitting: the three papers' methods and ours.

    from inclino.calib import fit
    cal, report = fit(dataset, "joint")

`fit(ds, method, **opts) -> (Calibration, FitReport)`; methods: joint (the
default), ren2014, li2021, guo2009.  The Calibration carries the method, the
probe serial, the data's hash and the report; `cal.save(path)` writes
CAL.json atomically.  Errors: DataError (bad or insufficient data, exit 2),
CalibrationError (singular or out-of-range result, exit 3).

The submodules (SciPy among their imports) load on first use, so that the
`inclino` command, which registers `calibrate`, starts quickly.
"""
from __future__ import annotations

import importlib
import time

METHODS = ("joint", "ren2014", "li2021", "guo2009")
DEFAULT_METHOD = "joint"
# A longer run is thinned to every k-th row before the fit
# (inclino.formats.dataset.thin; peak memory about 12 kB per fitted row in joint)
MAX_FIT_ROWS = 40_000

__all__ = ["fit", "FitReport", "METHODS", "DEFAULT_METHOD"]


def __getattr__(name):
    if name == "FitReport":
        from .report import FitReport

        return FitReport
    raise AttributeError(name)


def fit(ds, method: str = DEFAULT_METHOD, data_hash: dict | None = None, report: bool = True,
        max_rows: int | None = MAX_FIT_ROWS, **opts):
    import numpy as np

    from inclino.formats.dataset import thin

    from inclino.errors import CalibrationError, DataError

    from . import common
    from . import report as report_mod

    if method not in METHODS:
        raise DataError(f"unknown calibration method {method!r} (one of {', '.join(METHODS)})")
    if len(ds) == 0:
        raise DataError("the dataset has no rows")
    mod = importlib.import_module(f"inclino.calib.{method}")
    data_hash = data_hash or common.dataset_hash(ds)  # of every row, before thinning
    ds, thinned = thin(ds, max_rows)
    t0 = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            cal, info = mod.fit(ds, **opts)
            if method == "joint" and opts.get("temperature", "auto") != "off":  # calib/thermal.py
                from . import thermal
                from .joint import SIGMA_ACC, SIGMA_MAG, SIGMA_POSE_DEG

                cal, info = thermal.fit(ds, cal, info, opts.get("temperature", "auto"),
                                        opts.get("sigma_acc", SIGMA_ACC), opts.get("sigma_mag", SIGMA_MAG),
                                        opts.get("sigma_pose_deg", SIGMA_POSE_DEG), bool(opts.get("fix_dip")))
    except np.linalg.LinAlgError as e:
        raise CalibrationError(f"{method}: singular fit ({e})")
    elapsed = time.perf_counter() - t0
    cal.data = data_hash
    rep_ds = info.pop("report_dataset", ds)  # joint --temperature-terms: the readings brought to t_ref
    rep = None
    if report:
        refit = (lambda d: mod.fit(d, **opts)[0]) if "covariance" not in info else None
        with np.errstate(all="ignore"):
            rep = report_mod.build(rep_ds, cal, method, info, refit, opts)
        rep.fit_time_s = elapsed
        if thinned:
            rep.notes.append(thinned)
        cal.report = rep.to_dict()
    return cal, rep
