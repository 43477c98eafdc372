"""A log without poses read while the sensor moved by hand: the holds it
has, fitted alone, and the motion named where nothing can be calibrated.

A hand that turns a phone or a board from orientation to orientation
accelerates it, and the accelerometer reads gravity plus that acceleration,
which no sensor model explains.  A step-and-hold log (its holds at least
half its rows) already has its holds fitted and the rows read between them
left out (inclino.holds.determining).  A log read mostly while moving was
fitted on every row: its |g| residual was the hand's (tests/data/real/
mpu6050_tedaldi with each hold cut to its first 20 rows, 70 % of the rows
moving: 35 mg on every row, 5.3 mg on its 42 holds alone, with the offsets
of the source's own calibration), and where the motion kept the ellipsoid
from being determined at all the refusal blamed the orientations ("they
cover too little of the sphere") of a sensor turned through all of them
(tests/data/real/mpu6050_sphere, rows 2550-2849: directions spread 0.20).

* `holds_fit(ds, triads, R, sigma)`: the holds of a log read mostly while
  moving (inclino.holds.moving_holds: at least 12, determining every present
  triad's ellipsoid) when the rows read while moving misfit the holds'
  ellipsoid at least MOTION_K times more than the holds' own rows (robust
  spread of the |g| residual): a hand's acceleration, not a slow turn, whose
  rows fit as well as a hold's and are kept.
* `figures(ds)`: what the log shows of its motion (share of rows read while
  moving, holds found, |g| as logged), or None when it is not read mostly
  while moving, or |g| does not change within HOLD_ROWS rows by more than
  HOLD_K times the noise (a sensor stepped at rest from row to row, each
  row an orientation of its own, moves without accelerating).
* `named(ds, what)`: the refusal's text when the fit of every row fails and
  the readings' directions span the sphere (PLENTY_EIG): the motion, with
  its figures and the fix; None otherwise (the orientations' own reason
  stands).
* `verdict_cause(figures)`: the same cause, for a |g| residual that fails
  the verdict of a calibration written; `cause(figures)`, for the |g|
  residual's structure that `inclino diagnose` finds.
"""
from __future__ import annotations

import numpy as np

from inclino import holds

MOVING_SHARE = 1.0 - holds.STEP_AND_HOLD_FRACTION  # more than this share of the rows read while moving
MOTION_K = 3.0     # the moving rows' |g| residual spread over the holds' own, under the holds' fit: a hand's motion
PLENTY_EIG = 0.1   # readings whose directions' least second moment is at least this span the sphere (1/3: evenly)
PLENTY_COND = 1e3  # ... or whose directions alone determine an ellipsoid to this condition number (a hemisphere: 3e2)


def _robust_sd(x) -> float:
    x = np.asarray(x, float)
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if len(x) else 0.0


def figures(ds) -> dict | None:
    """The motion of an accelerometer log without poses read mostly while
    moving: {"rows", "moving_share", "holds", "acc_norm_spread_g" (robust
    1 sigma of |g| as logged), "acc_norm_jitter_g" (the median standard
    deviation of |g| over HOLD_ROWS consecutive rows), "acc_noise_g" (the
    noise holds.find used), "direction_spread" (least eigenvalue of the
    readings' directions' second moment)}; None for a log with poses or a
    pose id, declared static, without an accelerometer, whose holds hold at
    least half its rows, or whose |g| changes within HOLD_ROWS rows by no
    more than HOLD_K times the noise."""
    from .triad import direction_cond, direction_spread

    if not getattr(ds, "has_acc", False) or len(ds) < holds.HOLD_ROWS or holds.labelled(ds) \
            or holds.declared_static(ds):
        return None
    h = holds.find(ds)
    n = len(ds)
    share = h.rows_moving / n
    if share <= MOVING_SHARE:
        return None
    acc = np.asarray(ds.acc, float)
    norm = np.linalg.norm(acc, axis=1)
    # |g| within HOLD_ROWS rows: a hand's acceleration changes it by tens of mg (27-49 mg on the corpus's
    # hand-moved logs), a sensor turned or stepped at rest by its noise (2-5 mg on the step-and-hold ones)
    jitter = float(np.median(holds._window_std(np.repeat(norm[:, None], 3, 1), holds.HOLD_ROWS)[:, 0]))
    noise = float(np.mean(h.noise["acc"]))
    if jitter <= holds.HOLD_K * noise:
        return None
    return {"rows": n, "moving_share": float(share), "holds": int(h.count),
            "acc_norm_spread_g": _robust_sd(norm), "acc_norm_jitter_g": jitter, "acc_noise_g": noise,
            "direction_spread": direction_spread(acc), "direction_cond": direction_cond(acc)}


def _text(f: dict) -> str:
    return (f"{100 * f['moving_share']:.0f} % of the {f['rows']} rows were read while moving (in no "
            f"{holds.HOLD_ROWS} consecutive rows still within {holds.HOLD_K:g}x the noise) and |g| as logged spreads "
            f"{f['acc_norm_spread_g']:.3g} g (robust 1 sigma), changing by {1e3 * f['acc_norm_jitter_g']:.3g} mg "
            f"within {holds.HOLD_ROWS} rows (median) against a noise of {1e3 * f['acc_noise_g']:.3g} mg")


FIX = (f"hold the device still at each orientation (at least {holds.MIN_HOLDS} holds of at least "
       f"{holds.HOLD_ROWS} rows, in varied directions) and log again, or declare the run static (--static) only if "
       f"every row was read at rest")


def holds_fit(ds, triads, R: float, sigma: float):
    """(hold of each row, -1 moving; hold count; figures with "motion_ratio",
    "held_spread_g", "moving_spread_g") when the log is read mostly while
    moving, its holds determine every present triad's ellipsoid and its
    moving rows misfit the holds' accelerometer ellipsoid at least MOTION_K
    times more than the holds' rows; else None."""
    from inclino.errors import CalibrationError, DataError

    from . import triad

    f = figures(ds)
    if f is None:
        return None
    mh = holds.moving_holds(ds, triads)
    if mh is None:
        return None
    labels, count = mh
    held = labels >= 0
    acc = np.asarray(ds.acc, float)
    try:
        M, b, _, _ = triad.fit_sphere(acc[held], R, sigma, min_rows=12, what="the accelerometer")
    except (DataError, CalibrationError):
        return None
    r = np.linalg.norm((acc - b) @ M.T, axis=1) - R
    s_held, s_moving = _robust_sd(r[held]), _robust_sd(r[~held])
    ratio = s_moving / max(s_held, 1e-12)
    if ratio < MOTION_K:
        return None
    return labels, count, {**f, "holds": int(count), "held_spread_g": s_held, "moving_spread_g": s_moving,
                           "motion_ratio": float(ratio)}


def note(f: dict, moving_rows: int) -> str:
    """The report's note of a moving log whose holds were fitted alone."""
    return (f"holds: a log read mostly while moving ({100 * f['moving_share']:.0f} % of its rows): its "
            f"{f['holds']} static holds found in the readings were fitted, the {moving_rows} rows read while moving "
            f"left out: under the holds' fit their |g| residual spreads {1e3 * f['moving_spread_g']:.3g} mg against "
            f"the holds' {1e3 * f['held_spread_g']:.3g} mg (robust 1 sigma): the hand's acceleration")


def named(ds, what: str = "the accelerometer") -> str | None:
    """The refusal's text when a fit of every row of a log read mostly while
    moving failed although its readings' directions span the sphere (at
    least PLENTY_EIG): the motion, not the orientations; None otherwise."""
    f = figures(ds)
    if f is None or (f["direction_spread"] < PLENTY_EIG and f["direction_cond"] > PLENTY_COND):
        return None
    few = (f"{f['holds']} holds found, too few, or in too few directions, to determine it alone"
           if f["holds"] else "no hold found")
    return (f"{what} moved while it was read: {_text(f)}: the hand's own acceleration, not the orientations "
            f"(their directions span the sphere: spread {f['direction_spread']:.2f}, 1/3 for every direction; they "
            f"alone determine an ellipsoid to a condition number of {f['direction_cond']:.3g}, 2.5 for every "
            f"direction), keeps "
            f"{what}'s ellipsoid from being determined ({few}); {FIX}; no calibration written")


def verdict_cause(f: dict | None) -> str:
    """The cause to name beside a failing |g| residual of a log read mostly
    while moving ('' for none)."""
    return "" if f is None else f" (the motion: {_text(f)}; {FIX})"


def cause(f: dict) -> str:
    """The motion as the cause of structure in the |g| residual (inclino
    diagnose without poses)."""
    return (f"the sensor moved while it was read: {_text(f)}: the hand's acceleration, which no sensor effect "
            f"models; {FIX}")


def refusal(ds, e, hs, hl) -> str | None:
    """The text of a refusal for a pose-free fit that failed (e: the fit's
    error; hs: the holds fitted alone, None when every row was; hl: the
    holds found, determining or not): where the holds were fitted alone,
    the terms they leave free (holds.undetermined_text: they passed the
    leverage test, not the test of free terms); else the motion (named)
    where a log read mostly while moving failed on its accelerometer; else
    the holds, where holds were found but leave the failing triad's
    ellipsoid free, with what the fit of every row then met (its own
    error whole, which names the terms the rows leave free); None: the
    fit's own error stands."""
    import re

    from inclino import holds

    msg = str(e)
    t = "acc" if "accelerometer" in msg else "mag" if "magnetometer" in msg else None
    if t is None:
        return None
    what = "the accelerometer" if t == "acc" else "the magnetometer"
    met = re.split(r" \(|: ", msg, maxsplit=1)[0]
    if hs is not None:
        # the holds fitted alone and failing: what they leave free (a Pololu MinIMU-9's 183 holds, all within
        # 6 deg of x, passed the leverage test and were refused as "readings on a few circles or in a plane")
        text = holds.undetermined_text(ds, hs[0], hs[1], t, what) if getattr(ds, f"has_{t}", False) else None
        return None if text is None else f"{text}; fitted on them alone: {met}; no calibration written"
    if t == "acc":
        cause = named(ds, what)
        if cause is not None:
            return cause
    if hl is None or not getattr(ds, f"has_{t}", False):
        return None
    text = holds.undetermined_text(ds, hl[0], hl[1], t, what)
    if text is None:
        return None
    # the every-row fit's own error whole: which terms its rows leave free (ellipsoid.ellipsoid_start)
    return (f"{text}; fitted on every row instead, the {int(np.sum(hl[0] < 0))} rows read while moving between them "
            f"too: {msg}; no calibration written")
