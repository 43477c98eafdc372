"""Checks before any fit: does a dataset look like what it says it is?

    rep = checks.run(ds)          # a CheckReport
    rep.raise_errors()            # DataError (exit 2) on data that cannot be right

Each finding is one line that names the likely cause and the fix.  Data
that cannot be right are errors (the commands exit 2 before any fit):

* units -- |g| far from 1 g (or the header's gravity_g), |b| outside the
  geomagnetic range (or far from the header's field_nT): the unit it looks
  like is named;
* handedness -- the magnetometer's axes mirrored against the
  accelerometer's (the dip angle g.b/|g||b| is consistent only through a
  reflection), or a triad mirrored against the poses, unless the header
  declares the reflection intended (`# reflection=acc|mag`);
* row alignment -- the triads paired out of step: the dip angle (or a
  triad's fit to the poses) is far more consistent with the rows shifted;
* dip sign -- the dip opposite to the header's: the accelerometer's gravity
  sign turned;
* time unit -- the sensor turning faster than 10^5 deg/s by the declared
  time unit (a warning within what a rig or a spin could do);
* temperature -- an imported log's temp_c equal to a pose or sensor column (refused); exactly linear in time (a note).

Suspicious data are warnings (the fit runs; the warning is in its report):
a scale or field off by more than a sensor plausibly is, the magnetometer's
axes rotated against the accelerometer's, a smaller shift, readings at the
declared range (saturated: left out of the fit), a run declared static
whose readings move, a time column whose unit puts the rows or the turning
outside what loggers and hands do (the unit they look like named).  Notes: whether the run is static or moving (from the
readings' own spread, not from a time column), the noise of each triad,
every row one orientation (calibrate and diagnose refuse it: undetermined),
a constant temperature, a canonical dataset's temp_c that is no temperature.

The thresholds are physical (docs/dataset.md, "Checks before any fit"):
GRAVITY_TOL, GEOMAGNETIC_NT, FIELD_TOL, DIP_* below.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from inclino.calib.ellipsoid import determined, on_shell, signed_permutations, sphere
from inclino.errors import DataError
from inclino.formats.dataset import POSE_COLS
from inclino.formats.sensor import STANDARD_GRAVITY
from inclino.holds import NOISE_BOUND, declared_static  # NOISE_BOUND: the most noise a static sensor has (g, nT)

# |g| / G: uncalibrated MEMS accelerometers are within a few % in scale and
# ~0.1 g in offset; beyond +-15 % is a warning, beyond 0.5x-2x cannot be g
GRAVITY_TOL = (0.85, 1.15)  # |g| / gravity_g: a warning outside (a MEMS part: a few % in scale; the ADXL345 +-10 %)
GRAVITY_UNITS = (0.5, 2.0)
NO_SIZE = 1e-200            # |g| (g) or |b| (nT) below it: no reading at all (a denormal's ratios underflow)
GRAVITY_REMOVED_SPREAD = 0.2  # |a|'s median deviation over its median, |a| below 0.5 g and not on a shell: gravity
                              # removed (an iPhone's Sensor Logger export: 0.022 g, wandering 55 %; isotropic noise
                              # 30 %; 30 hand-held and rig logs of real sensors 0.4 to 16 %)
# the main field at the Earth's surface (IGRF): 22 000 nT (South Atlantic) to 67 000 nT (magnetic poles)
GEOMAGNETIC_NT = (22_000.0, 67_000.0)
MAGNET_MAX_NT = 5e6        # a field up to this (5 mT, the AK8963's full scale) can be a magnet's near the sensor
MAG_UNIT_TOL = 1.8         # a unit that brings |b| within this factor of 45 000 nT explains it (exp of the guesses' 0.6)
GEOMAGNETIC_SLACK = 1.5   # a sensor's scale error and a steel building: a warning within 1.5x, an error beyond
FIELD_TOL = (0.8, 1.25)   # |b| / header field_nT: a warning outside
FIELD_UNITS = (0.4, 2.5)  # |b| / header field_nT: an error outside (a unit)
NORMALISED_TOL = 0.15     # |b| within this of 1 in the declared unit, and no site's field: readings normalised
RANGE_STEP_TOL = 0.1      # |g| or |b| within 10 % of 2, 4 or 8 times (or 1/2, 1/4, 1/8) the expected: the lsb
                          # or range setting named (a range setting doubles the lsb: the commonest scale mistake)
DIP_MISMATCH_DEG = 10.0   # |dip - header dip| beyond it: a warning
DIP_SIGN_MIN_DEG = 5.0    # a dip's sign is compared with the header's only when both are beyond this
POSE_MISFIT_DEG = 20.0    # gravity's directions miss the poses' by more (median) with the best rotation: an error
AXES_TURN_DEG = 20.0      # the accelerometer turned more against the poses (and fitting AXES_RATIO x better): a
                          # warning naming the map
MAX_LAG = 3               # row shifts tried between the triads ...
LAG_WIDE = 50             # ... and, for a shift beyond them, this many either way (_wide_lag) ...
LAG_WIDE_PAIRED = 12      # ... leaving at least this many rows paired ...
LAG_WIDE_JUMP_ROWS = 6_000  # ... (the jumps route: its running medians on logs of this many rows at most)
LAG_RATIO = 3.0           # spread as paired / spread at the best shift: an error beyond (and > 2 deg)
LAG_MIN_GAIN = 0.1        # a warning when the best shift cuts the spread by more than this fraction ...
LAG_NEIGHBOUR = 0.05      # the spread at a shift beside the one named within this share of its own: the row not fixed
LAG_MIN_DEG = 0.1         # ... and by more than this
MIN_SPREAD_DEG = 1.0      # a dip spread below this is consistent whatever the shift
LAG_T = 3.0               # step-and-hold logs: the paired mean-deviation gain of a shift must be this many
                          # standard errors (of blocks of rows) to be named ...
LAG_T_GAIN = 1.5          # ... and cut the mean deviation by this factor
LAG_JUMP_K = 6.0          # a log read at a few positions: a row is brought back (or put out) by a shift when its
LAG_JUMP_DEG = 1.0        # dip deviation changes by this many times the row-to-row noise and degrees ...
LAG_JUMP_WINDOW = 31      # ... from the running median of this many rows' dips (a hold's, through a turn) ...
LAG_JUMP_MIN_ROWS = 3     # ... a shift named when it brings back this many rows ...
LAG_JUMP_RATIO = 10       # ... and puts out at most a tenth as many
LAG_CURVE_ROWS = 2000     # continuously moving logs: the dip invariant's lag curve needs this many rows ...
LAG_CURVE_SHORT_ROWS = 200  # ... (from this many, a curve whose standard error is the larger of two jackknifes,
                            # the second refitting the triads' calibration and the lever arms without each block,
                            # that names a row by its strict rule with each half of the log rounding to that row,
                            # its standard error below LAG_CURVE_NEAREST_SE and its fraction within
                            # LAG_CURVE_SHORT_LEFT of the row, or that puts the rows in step: on fewer rows the
                            # first jackknife's standard error is too small to carry the nearest-row warning, the
                            # notes or the other routes' second view)
LAG_CURVE_SHORT_LEFT = 0.4
LAG_CURVE_POSSIBLE_SE = 1.0  # ... and one that names no row is said as a note below this standard error (rows)
LAG_CURVE_BLOCKS = 20     # ... cut in this many blocks for its jackknife standard error;
LAG_CURVE_MIN_TURN_BLOCKS = 8  # ... the triads' turning spread over at least this many blocks' worth (_turn_blocks:
                               # real logs turned by hand 9-19, stretches of 300-1 500 rows too but two of BROAD's
                               # 600 rows at 5.7 and 6.6; six positions held, 4.5-6.5);
LAG_CURVE_SE = 3.0        # a whole-row shift is named when the fractional lag is this many standard errors
                          # beyond half a row (and each half of the log, fitted on its own, rounds to it)
LAG_CURVE_NEAREST_SE = 0.5  # ... or, as a warning, the nearest whole row when the curve's standard error is
                            # below this and each half of the log lies on that side of zero
LAG_CURVE_PARTS = 2        # ... and fitted in this many parts of the log, each with its own nuisance terms
LAG_CURVE_MAX_RESULTANT = 0.95  # ... and both triads' directions to turn: their mean resultant length below this
HELD_FRAC = 0.5          # a triad whose reading repeats the row before on this share of rows, ...
HELD_OTHER = 0.05        # ... the other's on less than this: sampled slower and held (no pairing to a row)
LAG_CURVE_MIN_SIN = 0.1   # |sin dip| below it (within ~6 deg of the magnetic equator): no invariant to scale
LAG_LEVER_ROWS = 9        # the lag curve's lever-arm terms: the triads' directions smoothed over this many rows
                          # (Savitzky-Golay, cubic) before the rotation rate is taken from them ...
LAG_LEVER_ACC_WEIGHT = 0.1  # ... with the accelerometer's direction weighted this much against the magnetometer's
                            # (the accelerometer's carries the hand's acceleration the terms fit out)
GYRO_LAG_SHARP = 0.96      # a triad's lag against the gyroscope: the residual of its row differences fitted on the
                           # gyroscope's turn of its vector at the best lag below this share of the residual at either
                           # neighbouring lag, in each half of the log (measured below)
GYRO_LAG_MIN_ROWS = 200    # ... on at least this many consecutive rows
GYRO_LAG_SMOOTH_ROWS = 3   # ... the differences and the turns each summed over this many rows (a linear filter, the
                           # same at every lag: BROAD 05's accelerometer 0.94 -> 0.84, its hand's jerks averaged)
AXES_RATIO = 3.0          # dip spread with the declared maps / with the best other map
HAND_WEAK_RATIO = 1.2     # below AXES_RATIO: a reflection that cuts the dip's spread this much (and HAND_WEAK_DEG) ...
HAND_WEAK_DEG = 0.2
HAND_WEAK_HALF = 1.1      # ... and cuts it this much in each half of the log on its own: a warning
HAND_NOTE_RATIO = 1.5     # the declared map beats every one-axis mirror by less than this: a note (checked on little)
POSE_FIT_KEEP = 0.9        # the accelerometer's directions against the poses: the best 90 % of rows (_acc_poses)
POSE_SAME_DEG = 10.0      # two poses whose gravity lies POSE_APART_DEG or more apart, their rows' median directions
POSE_APART_DEG = 30.0     # within this (and a third of the poses' angle): one direction read under two poses
POSE_GROUP_ROWS = 3       # ... each pose on at least this many rows
RAW_DIRS_MAX_CV = 0.1     # raw directions compared only when |v| varies less than this (offsets small)
CHECK_ROWS = 200_000      # rows looked at (stratified random rows beyond: _thin; the lag on the first LAG_ROWS consecutive rows)
LAG_ROWS = 50_000
MOTION_MIN_HOLDS = 4       # a log of fewer than this many holds' rows is too short to tell a slow turn by its holds
HOLDS_MOVING_NOTE = 0.01   # a still log's rows read while moving between holds: a note from this share on

# the time column (the unit it was declared in): what a logger and a turning sensor do
STATIC_MOVING_K = 3.0                # a log declared static whose rows between its holds misfit the holds'
STATIC_MOVING_MIN_ROWS = 20          # ellipsoid this many times its holds' rows (at least this many rows): moving
UNIX_S = (946_684_800.0, 2_208_988_800.0)  # Unix times of 2000-01-01 and 2040-01-01: a log's clock stamps Unix
                                     # time in this range; a first row's time beyond it, in s, is no clock's
ROW_RATE_HZ = (1.0 / 600.0, 1e5)     # rows/s outside it: a warning (a row every 10 min on a moving log; a logger
                                     # writing a row per sample faster than 100 kHz)
TURN_RATE_DEG_S = (1.0, 5000.0)      # the median rate a hand or a rig turns the sensor at, between its moving rows;
                                     # outside it (rows turning by TURN_MIN_DEG_ROW or more): a warning
TURN_RATE_MAX_DEG_S = 1e5            # beyond it (about 280 turns a second) it cannot be right: an error
TURN_MIN_DEG_ROW = 1.0               # the too-slow side needs the moving rows to turn by this much a row
TURN_NOISE_K = 8.0                   # a pair of rows moves when its readings differ by this many times the noise ...
TURN_MAX_CHORD_DEG = 30.0            # ... and turn by less than this (a rate, not the angle between two holds)
TURN_MIN_PAIRS = 20                  # ... in at least this many pairs (and 2 % of them) at the shortest lag
TYPICAL_ROW_RATE_HZ = (0.5, 20000.0) # a unit named for the rows makes their rate this ...
TYPICAL_TURN_DEG_S = (2.0, 2000.0)   # ... and the turning this
TURN_SEEN_DEG_S = (50.0, 2000.0)     # the corpus' moving logs turn at a median 99.6 (BROAD 05) to 1291 deg/s
                                     # (AirbrakesV2's faces lifted and set down): a unit that puts the turning here
                                     # is named before one that puts it merely within TYPICAL_TURN_DEG_S, and two
                                     # units that both put it here are named together (nothing in the rows tells
                                     # them apart: a 100 us tick counter declared us reads as ms too, 10x slower)
NOT_TIME_STILL = 0.5                 # a time column standing still on more than this share of its steps ...
NOT_TIME_BACK = 0.02                 # ... and going back on more than this share: not a time
TIME_FACTORS = (1e-3, 1e3, 1e-6, 1e6, 1e-9, 1e9, 60.0, 1.0 / 60.0, 3600.0, 1.0 / 3600.0)  # units tried (x the
                                     # declared one), in this order: a prefix (ms for s) is the usual slip
# the temperature column
TEMP_RATE_MAX_C_S = 2.0              # a sensor's temperature changing faster than this, sustained over a run of rows:
                                     # no sensor's (a chamber ramps at up to ~0.3 degC/s, a part warming after power-on
                                     # by a few degC over tens of seconds): the time column's unit is too small
TEMP_RATE_TYPICAL_C_S = 0.5          # a unit named for it makes the temperature's rate at most this
TEMP_RATE_MIN_ROWS = 50              # ... judged on runs of rows in time order of at least this many rows ...
TEMP_RATE_SIGNIF = 10.0              # ... whose trend is this many standard errors from none
TEMP_EXACT = 1e-6                    # a column equal to another up to scale and offset within this share of its range
ACC_OFFSET_G = 0.25  # the accelerometer's sphere centred farther from zero on an axis: a warning (MEMS parts'
                    # zero-g offsets are within ~0.15 g; the corpus' largest 0.10 g, a tag's 0.64 g on z)
ONE_ORIENTATION_DEG = 5.0            # every triad's rows within this of their median direction (95 %): one orientation

ACC_UNIT_GUESS = {"m/s^2": 9.80665, "mg": 1000.0, "cm/s^2 (Gal)": 980.665, "ft/s^2": 32.174, "ug": 1e6,
                  **{f"counts at {2 ** k} per g": float(2 ** k) for k in range(8, 16)}}
MAG_UNIT_GUESS = {"uT": 1e-3, "gauss": 1e-5, "mG": 1e-2, "tesla": 1e-9, "counts of 0.15 uT": 1 / 150.0,
                  "counts of 0.3 uT": 1 / 300.0, "counts of 0.6 uT": 1 / 600.0}  # values per nT


@dataclass
class Finding:
    check: str          # units, handedness, poses, row-alignment, dip-sign, axes, saturation, motion, noise, time,
                        # time-order, ...
    level: str          # error, warning, note
    message: str        # one line: what, the likely cause, the fix
    triad: str | None = None
    figures: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"check": self.check, "level": self.level, "triad": self.triad, "message": self.message,
                "figures": self.figures}


@dataclass
class CheckReport:
    rows: int
    triads: str
    findings: list = field(default_factory=list)
    static: bool | None = None           # measured (None: not decidable)
    declared_static: bool = False
    lag_rows: int = 0                    # magnetometer rows behind the accelerometer's (0: in step)
    mag_to_acc: list | None = None       # the signed permutation that best aligns the magnetometer (3x3)
    noise: dict = field(default_factory=dict)   # per triad, RMS of one reading (g, nT), from the data
    saturated: list = field(default_factory=list)  # row indices at the declared range
    lag_curve: dict | None = None        # the dip invariant's fractional lag (rows), its standard error, halves
    time: dict | None = None             # rows/s and turning rate by the declared time unit, the unit they look like
    one_orientation: dict | None = None  # every row one orientation held: each triad's spread (deg) (one_orientation())

    @property
    def errors(self):
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self):
        return [f for f in self.findings if f.level == "warning"]

    def lines(self, levels=("error", "warning")) -> list:
        return [f"{f.level}: {f.message}" for f in self.findings if f.level in levels]

    def raise_errors(self) -> None:
        errs = self.errors
        if errs:
            more = f" (and {len(errs) - 1} more: {'; '.join(e.check for e in errs[1:])})" if len(errs) > 1 else ""
            raise DataError(errs[0].message + more)

    def to_dict(self) -> dict:
        return {"rows": self.rows, "triads": self.triads, "static": self.static,
                "declared_static": self.declared_static, "lag_rows": self.lag_rows,
                "mag_to_acc": self.mag_to_acc, "lag_curve": self.lag_curve, "noise": self.noise, "saturated_rows": len(self.saturated),
                "time": self.time, "one_orientation": self.one_orientation,
                "findings": [f.to_dict() for f in self.findings]}


# ------------------------------------------------------------------ helpers
def _robust_std(x) -> float:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return float("nan")
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _imported(ds) -> bool:
    return "sensor" in ds.meta


def _fix(ds, section: str, what: str) -> str:
    if _imported(ds):
        return f"fix {what} in the sensor description's [{section}] and import again"
    return f"import the log with a sensor description that says {what} (inclino import LOG --sensor S.toml; " \
           f"docs/dataset.md)"


def _unit_dirs(v, R, held=None):
    """Readings as unit directions, after an algebraic ellipsoid fit when
    the orientations determine one (raw directions otherwise).  held: a
    callable giving the rows read at rest (the holds), whose fit stands in
    when the fit of every row finds no ellipsoid (the rows read while
    moving between the holds carry the hand's acceleration: an MPU-9250
    accelerometer 0.65 g off, fitted on every row, fell back to raw
    directions, whose dip spread 24 deg whatever the axis map, and the
    handedness was said to be checked on too little)."""
    from inclino.calib.ellipsoid import ellipsoid_start, far_mean

    v = np.asarray(v, float)
    u = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    # readings whose mean lies farther from the origin than the vector they read (a phone's hard-iron offset)
    # are fitted less their mean (ellipsoid.far_mean): fitted as logged, a phone's log looked like a few
    # orientations, its raw directions advised a wrong axis map, and the same readings less a constant
    # advised none
    vc = v - far_mean(v, R)
    uc = vc / np.maximum(np.linalg.norm(vc, axis=1, keepdims=True), 1e-300)
    distinct = len(np.unique(np.round(uc, 1), axis=0))

    def fitted(rows):
        """|M (v - b)| / R per row of the ellipsoid through `rows`, or None."""
        if not determined(rows, R):
            return None
        try:
            with np.errstate(all="ignore"):
                M, b = ellipsoid_start(rows, R)
            w = (v - b) @ M.T
        except (DataError, np.linalg.LinAlgError, ValueError):
            return None
        return w if np.all(np.isfinite(w)) else None
    if distinct >= 20:
        w = fitted(v)
        mask = None if held is None else held()
        if mask is not None and 20 <= mask.sum() < len(v):
            # the holds' ellipsoid where the fit of every row misfits the holds' own rows 3x more than it does
            wh = fitted(v[mask])

            def off(x):
                return float(np.median(np.abs(np.linalg.norm(x[mask], axis=1) / R - 1.0)))
            if wh is not None and (w is None or off(w) > 3.0 * off(wh)):
                w = wh
        if w is not None:
            n = np.linalg.norm(w, axis=1)
            if np.median(np.abs(n / R - 1.0)) < 0.2:
                return w / np.maximum(n[:, None], 1e-300), True
    return u, False


def _perm_text(m, letter="m") -> str:
    parts = []
    for i, b in enumerate("xyz"):
        j = int(np.argmax(np.abs(m[i])))
        parts.append(f"{b} = {'-' if m[i, j] < 0 else ''}{letter}{'xyz'[j]}")
    return ", ".join(parts)


def _declared_map(ds, triad="mag"):
    """The axis map the sensor description declared for the triad (body =
    map @ sensor, from the header's `mag_axes`), or the identity (a dataset
    not imported, or no map recorded)."""
    text = ds.meta.get(f"{triad}_axes")
    if not _imported(ds) or not text:
        return np.eye(3)
    from inclino.formats import sensor

    try:
        return sensor.axis_matrix(text, triad, f"{triad}_axes")
    except DataError:
        return np.eye(3)


def declared_reflection(ds, triad="mag") -> bool:
    """Whether the sensor description declared the triad's map a reflection
    (reflection = true: the header's `axes_reflection`)."""
    return _listed(ds, "axes_reflection", triad)


def _map_to_write(ds, P):
    """The magnetometer's map to write in the description's [magnetometer]
    axes, for the signed permutation P found in the body frame as imported
    (P @ body): P composed with the declared map, so that following it
    imports the data as P turns them (the declared map is the identity only
    without a description or preset).  (text, determinant)."""
    M = np.asarray(P, float) @ _declared_map(ds, "mag")
    return _perm_text(M), int(round(np.linalg.det(M)))


def _lag_to_write(ds, k: int) -> int:
    """The magnetometer's [magnetometer] lag that pairs the rows, for a shift
    k found in the data as imported: the declared lag plus k."""
    try:
        declared = int(ds.meta.get("mag_lag_rows") or 0) if _imported(ds) else 0
    except (TypeError, ValueError):
        declared = 0
    return declared + int(k)


def _dip(ug, ub):
    return np.degrees(np.arcsin(np.clip((ug * ub).sum(1), -1.0, 1.0)))


def _thin(n, limit):
    """The rows the checks look at: all, or `limit` of them stratified and
    seeded (inclino.formats.dataset.thin_rows: one at random in each of
    `limit` equal stretches), so a pattern repeating along the run cannot
    line up with the rows kept as it could with every k-th row."""
    from inclino.formats.dataset import thin_rows

    return np.arange(n) if n <= limit else thin_rows(n, limit)


# ------------------------------------------------------------------ checks
def _declared_factor(ds, triad: str):
    """The declared unit's size in the canonical unit (g, nT) of an imported
    triad (m/s2: 1/9.80665 g), or None (canonical data, counts, field units):
    a reading ratio r off the expected is then the readings in the unit whose
    size is that factor / r."""
    from inclino.formats import sensor

    unit = ds.meta.get(f"{triad}_unit")
    if not unit or not _imported(ds):
        return 1.0  # the canonical columns: g, nT
    return sensor.unit_size(unit, triad)


def _guessable(ds, triad: str, v, guess: dict) -> dict:
    """The unit guesses the logged values allow: counts only where they were
    whole numbers as logged (the canonical values over the declared unit's
    size).  An LSM303's decimals in uT declared nT were said to "look like
    counts of 0.6 uT or uT"."""
    size = _declared_factor(ds, triad)
    if not size or _whole(np.asarray(v, float) / size):
        return guess
    return {u: f for u, f in guess.items() if not u.startswith("counts")}


def _unit_guesses(ratio: float, guess: dict, canon: str, declared, tol: float) -> list:
    """The units the readings look like: `guess` holds values per canonical
    unit; a reading in unit U declared as D is ratio = size(D) x values-per-
    canon(U) off.  The declared unit itself (ratio 1) is never a guess."""
    cands = {canon: 1.0, **guess}
    for size in ([] if declared is None else [declared]) + [1.0]:
        # the log's numbers in another unit than declared; else the converted values (g, nT) in another unit
        out = [(abs(math.log(ratio / (size * f))), u) for u, f in cands.items() if abs(math.log(size * f)) > 1e-6]
        found = [u for d, u in sorted(out) if d < tol][:2]
        if found:
            return found
    return []


def _range_step(ratio: float) -> int:
    """k (+-1 ... +-3) when ratio is within RANGE_STEP_TOL of 2**k, else 0."""
    if not (np.isfinite(ratio) and ratio > 0):
        return 0
    k = int(round(math.log2(ratio)))
    return k if 1 <= abs(k) <= 3 and abs(ratio / 2.0 ** k - 1.0) <= RANGE_STEP_TOL else 0


LSB_UNITS = {"acc": (("g", 1.0), ("mg", 1e-3)), "mag": (("G", 1e5), ("uT", 1e3), ("mG", 100.0), ("nT", 1.0))}


def _one_over(x: float) -> int | None:
    """N where x is 1/N for a whole N >= 1 (as a description writes an lsb:
    1/16384 g), else None."""
    inv = 1.0 / x
    return round(inv) if inv >= 1.0 and abs(inv - round(inv)) < 1e-9 * inv + 1e-6 else None


def _lsb_parts(x: float, triad: str, exact: bool = False) -> tuple:
    """(number, unit) of an lsb (g, nT) as a sensor description spells it:
    1/N of a unit where N is whole (1/16384 g, 1/3000 G); else in g or uT,
    to 4 digits (a measured lsb), or to 6 with exact (a declared lsb a power
    of ten off: 1/3000 uT written for 1/3000 G was told "0.03333 uT")."""
    for unit, size in LSB_UNITS[triad][:None if exact else 1]:
        n = _one_over(x / size)
        if n is not None:
            return f"1/{n}", unit
    unit, size = LSB_UNITS[triad][0 if triad == "acc" else 1]
    return f"{x / size:.{6 if exact else 4}g}", unit


def _lsb_text(x: float, triad: str, exact: bool = False) -> str:
    return " ".join(_lsb_parts(x, triad, exact))


def _declared_lsb_text(lsb: float, fixed: tuple, k: int, triad: str) -> str:
    """The declared lsb, 10**k times the fixed one (number, unit), in the
    fixed one's number and the unit 10**k smaller where there is one (the
    lsb = "1/3000 G" advised, the declared "1/3000 uT", not "1/300000 G")."""
    sizes = dict(LSB_UNITS[triad])
    for unit, size in LSB_UNITS[triad]:
        if abs(sizes[fixed[1]] * 10.0 ** k / size - 1.0) < 1e-9:
            return f"{fixed[0]} {unit}"
    return _lsb_text(lsb, triad, True)


def _range_hint(ds, triad: str, ratio: float) -> str | None:
    """A reading 2, 4 or 8 times (or 1/2 ...) what it should be: the lsb or
    the range setting off by that factor, with the lsb to write for counts."""
    k = _range_step(ratio)
    if not k:
        return None
    f = 2 ** abs(k)
    out = f"the lsb or range setting looks {f}x off"
    lsb = ds.meta.get(f"{triad}_lsb_{'g' if triad == 'acc' else 'nT'}")
    if _counts(ds, triad) and lsb:
        return out + f" (lsb = \"{_lsb_text(float(lsb) / 2.0 ** k, triad)}\" for these counts, not " \
                     f"{_lsb_text(float(lsb), triad)})"
    return out


def _lsb_error(ds, triad: str, what: str, hint: str, fig: dict) -> Finding:
    """The error of counts read at another range than the declared lsb's."""
    name = "accelerometer" if triad == "acc" else "magnetometer"
    return Finding("units", "error", f"{name}: {what}: {hint}; "
                   + _fix(ds, name, "the lsb (the range setting the counts were read at)"), triad,
                   {**fig, "looks_like": []})


def _counts(ds, triad: str) -> bool:
    return _imported(ds) and str(ds.meta.get(f"{triad}_unit", "")).startswith("counts")


MID_SCALES = tuple(2 ** k for k in range(7, 24))  # unsigned counts read 2^(bits-1) at zero input


def _mid_scale(ds, triad: str, v) -> tuple | None:
    """(mid-scale, each axis' median in counts) of unsigned counts
    (2^(bits-1)) when every axis of an imported triad in counts reads about
    it: each axis' median within 5 % of one MID_SCALES value and farther
    from zero than 3 times its own spread (a signed triad's axes read about
    zero); else None."""
    if not _counts(ds, triad):
        return None
    lsb = ds.meta.get(f"{triad}_lsb_{'g' if triad == 'acc' else 'nT'}")
    c = np.asarray(v, float) / float(lsb or 1.0)  # back to counts
    med = np.median(c, axis=0)
    spread = 1.4826 * np.median(np.abs(c - med), axis=0)
    for z in MID_SCALES:
        # |median|: an accelerometer declared reads = "up" has had its sign turned
        if np.all(np.abs(np.abs(med) / z - 1.0) < 0.05) and np.all(np.abs(med) > 3.0 * spread):
            return z, np.abs(med)
    return None


def _whole_counts(ds, triad: str, v) -> bool:
    """Whether a triad declared in counts reads whole counts of its declared
    lsb (less any zero, a whole count too): 99 % of its values within 0.001
    count of one."""
    unit = "g" if triad == "acc" else "nT"
    lsb = ds.meta.get(f"{triad}_lsb_{unit}")
    if not (_counts(ds, triad) and lsb):
        return False
    return _whole(np.asarray(v, float) / float(lsb))


def _whole(k) -> bool:
    """Whether 99 % of the finite values k lie within 0.001 of a whole number."""
    k = np.asarray(k, float).ravel()
    k = k[np.isfinite(k)]
    return bool(k.size) and float(np.mean(np.abs(k - np.round(k)) < 1e-3)) >= 0.99


def _as_written(x: float) -> bool:
    """Whether x reads as a number a description would hold: four
    significant digits or fewer, or 1/N (an lsb in m/s2 read as g is
    0.000101972 g: no one wrote that)."""
    if not (np.isfinite(x) and x > 0):
        return False
    return abs(float(f"{x:.4g}") / x - 1.0) < 1e-9 or _one_over(x) is not None


def _counts_hint(ds, triad: str, ratio: float, tol: float) -> str:
    """The lsb that makes counts whose size is `ratio` off read the
    expected size ('' without a declared lsb): the declared lsb a power of
    ten off when ratio is within `tol` (in log) of one (a unit prefix
    slipped: an LSM9DS1's 0.14 mG written 0.14 uT was told to write
    "0.01267 uT", the lsb that puts the field mid-range, not the
    0.014 uT it is), else the lsb that makes it so."""
    unit = "g" if triad == "acc" else "nT"
    lsb = ds.meta.get(f"{triad}_lsb_{unit}")
    if not lsb or not (np.isfinite(ratio) and ratio > 0):
        return ""
    k = int(round(math.log10(ratio)))
    fixes = []  # (distance in log, the fix) of each slip within tol, the nearest said first
    if k and abs(math.log(ratio / 10.0 ** k)) < tol:
        # the same number in the unit 10**k away (1/3000 uT -> 1/3000 G), the declared lsb as written
        fixed = _lsb_parts(float(lsb) / 10.0 ** k, triad, True)
        fixes.append((abs(math.log(ratio / 10.0 ** k)),
                      f"lsb = \"{' '.join(fixed)}\", the declared lsb {_declared_lsb_text(float(lsb), fixed, k, triad)} "
                      f"{10 ** abs(k)}x too {'large' if k > 0 else 'small'} "
                      f"({'a unit prefix' if k % 3 == 0 else 'a unit or its prefix'} off?)"))
    swap = abs(abs(math.log(ratio)) - math.log(STANDARD_GRAVITY))
    said, meant = ("m/s2", "g") if ratio < 1 else ("g", "m/s2")
    number = float(lsb) * (STANDARD_GRAVITY if ratio < 1 else 1.0)  # as written, were it written in `said`
    if triad == "acc" and swap < tol and _as_written(number):
        # g and m/s2 swapped, 9.81x either way: within a sensor's scale error of ten, so both are said (an lsb of
        # 1 mg written "0.001 m/s2" was told only "0.00101972 g", ten times the number as written)
        fixes.append((swap, f"lsb = \"{number:.6g} {meant}\", the declared lsb {number:.6g} {said} in {meant} "
                            f"(g and m/s2 swapped?)"))
    if fixes:
        return " or ".join(text for _, text in sorted(fixes))
    return f"lsb = \"{_lsb_text(float(lsb) / ratio, triad)}\" would make it so"


UNIT_SPELLING = {"acc": {"g": "g", "m/s^2": "m/s2", "mg": "mg", "cm/s^2 (Gal)": "cm/s2", "ug": "ug"},
                 "mag": {"nT": "nT", "uT": "uT", "gauss": "G", "mG": "mG", "tesla": "T"}}


def _unit_fix(ds, triad: str, guesses: list, counts: str, ratio: float) -> str:
    """What to fix, in the sensor description's words: the lsb of counts
    (counts: the lsb hint), else the unit the readings look like, else the
    units of the kind other than the one declared (a log in g declared
    m/s2 was told to write unit = "m/s2", "mg" ..., and not "g"), the
    nearest first: the one that puts the size (ratio x the nominal as
    declared) nearest the nominal (an x-IMU's field of 20 150 nT written
    in nT and declared uT, 448x a geomagnetic field, was told "G", "mG",
    then "nT")."""
    name = "accelerometer" if triad == "acc" else "magnetometer"
    if counts:
        return _fix(ds, name, "the lsb")
    declared = str(ds.meta.get(f"{triad}_unit", "g" if triad == "acc" else "nT"))
    known = UNIT_SPELLING[triad]
    said = []
    for g in guesses:
        if g in known:
            said.append(f"unit = \"{known[g]}\"")
        elif g.startswith("counts at "):
            said.append(f"unit = \"counts\" with lsb = \"1/{g.split()[2]} g\"")
        elif g.startswith("counts of "):
            said.append(f"unit = \"counts\" with lsb = \"{g[len('counts of '):]}\"")
    if not said:
        from inclino.formats import sensor

        same = sensor.unit_size(declared, triad)
        units = _other_units(triad, same)
        if same is not None and np.isfinite(ratio) and ratio > 0:
            units.sort(key=lambda u: abs(math.log(ratio * sensor.unit_size(u, triad) / same)))
        said = [f"unit = \"{u}\"" for u in units]
        said.append("\"counts\" with lsb")
    return _fix(ds, name, "the unit (" + ", ".join(said[:-1]) + (" or " if len(said) > 1 else "") + said[-1] + ")")


def _unit_or_lsb(ds, triad: str, v, ratio: float, guess: dict, canon: str, tol: float, lsb_tol: float) -> tuple:
    """(units the readings look like, the lsb hint) of a triad `ratio` off
    its nominal size.  Whole counts declared: their lsb is the scale, and
    the lsb that makes the size nominal the fix, a power of ten off named as
    a unit prefix slipped (a MinIMU's counts 1000x off were said to "look
    like counts at 1024 per g or mg"; a magnetometer's 0.15 uT written
    0.15 nT was told unit = "uT" or counts of 0.6 uT, both refused when
    written); decimals declared counts are another unit (m/s2 read as
    counts)."""
    whole = _whole_counts(ds, triad, v)
    guesses = [] if whole else _unit_guesses(ratio, _guessable(ds, triad, v, guess), canon,
                                               _declared_factor(ds, triad), tol)
    counts = _counts_hint(ds, triad, ratio, lsb_tol) if _counts(ds, triad) and not guesses else ""
    return guesses, counts


def _mid_scale_error(ds, triad: str, v, fig) -> Finding | None:
    """The error of unsigned counts (every axis about one mid-scale value),
    or None: no unit or lsb fixes an offset (an Xsens ADC log read 3.48x
    g, and the lsb that made it 1 g imported every row as one
    orientation)."""
    mid = _mid_scale(ds, triad, v)
    if mid is None:
        return None
    z, med = mid
    name = "accelerometer" if triad == "acc" else "magnetometer"
    return Finding("units", "error", (
        f"{name}: every axis reads about {z} counts (medians {', '.join(f'{m:.0f}' for m in med)}): "
        f"unsigned counts with zero at mid-scale, which no unit or lsb fixes; "
        + _fix(ds, name, f"the zero: zero = {z} (the reading at zero input), then check the lsb")), triad,
        {**fig, "mid_scale_counts": z})


def _units_acc(ds, rows, rep):
    G = float(ds.meta.get("gravity_g") or 1.0)
    a = ds.acc[rows]
    n = np.hypot.reduce(a, axis=1)  # no overflow at 1e200
    S, how, med, sph = _size(a, lambda g: GRAVITY_UNITS[0] <= g / G <= GRAVITY_UNITS[1], "g", "g", shell_only=True)
    ratio = S / G
    fig = {"size_g": S, "how": how, "median_g": med, "expected_g": G, "ratio": ratio}
    said = f"{how}, {len(a)} rows"
    # unsigned counts first: their sphere's radius can be 1 g (or an lsb 4x off) about a centre at mid-scale,
    # which no lsb fixes (the median |g| had put them 3.5x off, past every other branch)
    mid = _mid_scale_error(ds, "acc", a, fig)
    if mid is not None:
        rep.findings.append(mid)
        return
    if GRAVITY_TOL[0] <= ratio <= GRAVITY_TOL[1]:
        _acc_offset(a, sph, med, G, rep)
        return
    if not (np.isfinite(ratio) and ratio > NO_SIZE):
        rep.findings.append(Finding("units", "error", (
            f"accelerometer: |g| is {S:.4g} ({said}): no gravity in the readings (a dead sensor, "
            f"or the wrong columns)"), "acc", fig))
        return
    hint = _range_hint(ds, "acc", ratio)
    if GRAVITY_UNITS[0] <= ratio <= GRAVITY_UNITS[1]:
        rep.findings.append(Finding("units", "warning", (
            f"accelerometer: |g| is {S:.4g} g ({said}), {100 * (ratio - 1):+.0f} % from "
            f"{G:g} g: more than a sensor's scale error; "
            + (hint if hint else "check the unit and lsb (the range setting?)")), "acc", fig))
        _acc_offset(a, sph, med, G, rep)
        return
    if hint and _counts(ds, "acc"):  # counts: the lsb declared is the scale
        rep.findings.append(_lsb_error(ds, "acc", f"|g| is {S:.4g} ({said}), {ratio:.4g}x "
                                                  f"{G:g} g", hint, fig))
        return
    wander = float(np.median(np.abs(n - med))) / med
    if ratio < GRAVITY_UNITS[0] and wander > GRAVITY_REMOVED_SPREAD and not _shell_of(a):
        # |a| wanders with an offset too (an MPU-9250 0.65 g off: 33 %), but its readings lie on a shell
        rep.findings.append(Finding("units", "error", (
            f"accelerometer: |g| is {S:.4g} ({said}), not {G:g} g, and it wanders "
            f"{100 * wander:.0f} % about that median (a unit scales every row alike): acceleration with gravity "
            f"removed (a phone app's linear or user acceleration), which no unit fixes; log the raw accelerometer, "
            f"with gravity"), "acc", {**fig, "wander": wander}))
        return
    guesses, counts = _unit_or_lsb(ds, "acc", a, ratio, ACC_UNIT_GUESS, "g", 0.2, 0.2)
    like = (f"the readings look like {' or '.join(guesses)}" if guesses else
            f"the readings are {ratio:.4g}x what g would be" + (f": {hint}" if hint else "")
            + (f" ({counts})" if counts else ""))
    unit = ds.meta.get("acc_unit", "g")
    rep.findings.append(Finding("units", "error", (
        f"accelerometer: |g| is {S:.4g} ({said}), not {G:g} g: {like}, not {unit}; "
        + _unit_fix(ds, "acc", guesses, counts, ratio)), "acc",
        {**fig, "looks_like": guesses}))


def _acc_offset(a, sph, med, G, rep) -> None:
    """A warning where the sphere the accelerometer's readings lie on is
    centred farther from zero than a MEMS part's offset (ACC_OFFSET_G on an
    axis), naming it per axis, and saying when it is more than the probe's
    calibration format holds (calfile.ACC_B_LIMIT: calibrate refuses it)."""
    if sph is None:
        return
    from inclino.formats.calfile import ACC_B_LIMIT

    c = np.asarray(sph[0], float) / G
    if not np.abs(c).max() > ACC_OFFSET_G:
        return
    xyz = ", ".join(f"{v:+.3g}" for v in c)
    beyond = np.abs(c).max() >= ACC_B_LIMIT
    rep.findings.append(Finding("units", "warning", (
        f"accelerometer: the readings lie on a sphere of {sph[1] / G:.4g} g centred ({xyz}) g from zero (x, y, z; "
        f"their median |g| {med / G:.3g} g): an offset beyond a MEMS part's ~0.1 g"
        + (f", and beyond the +-{ACC_B_LIMIT:g} g the probe's calibration holds (calibrate refuses it)"
           if beyond else ", which the calibration's offset takes out")
        + "; check the zero (a declared zero, or unsigned counts read signed), or the part"), "acc",
        {"offset_g": c.tolist(), "size_g": float(sph[1] / G), "median_g": med / G}))


def _shell_of(v) -> bool:
    """Whether the readings determine a sphere and lie on it as on a shell (ellipsoid.on_shell)."""
    sph = sphere(v)
    return sph is not None and on_shell(v, sph)


def _plausible_field(b, F) -> bool:
    """|b| within the units check's own limits: against the header's field
    (FIELD_UNITS) or, without one, the geomagnetic range (GEOMAGNETIC_SLACK)."""
    if F:
        return FIELD_UNITS[0] <= b / float(F) <= FIELD_UNITS[1]
    return GEOMAGNETIC_NT[0] / GEOMAGNETIC_SLACK <= b <= GEOMAGNETIC_NT[1] * GEOMAGNETIC_SLACK


def _size(v, plausible, sym: str, unit: str, shell_only: bool = False) -> tuple:
    """(size, how, median |v|, sphere or None) of one triad's readings, the
    figure its units check judges: the radius of the sphere the readings lie
    on, which an offset does not move (a tag's accelerometer 0.64 g off on z
    read a median |g| of 0.41 g and was told an lsb 2.4x off), else (the
    orientations span no sphere) the median |v|.  A sphere whose radius is
    implausible where the readings' own median is plausible, and on which
    they lie as a blob rather than a shell, is one their orientations do not
    determine: the median then (a drone standing in an office: readings
    within 5 uT of one another, a "sphere" of 6 uT through them, their |b|
    31 uT; called 8x off).  shell_only (the accelerometer, whose readings
    move off gravity's sphere with the hand's acceleration): a sphere only
    where the readings lie on it as a shell (a six-face session lifted
    between its faces: a sphere of 1.17 g through readings of 1.00 g).
    `how` says which, in the message's words."""
    sph = sphere(v)
    med = float(np.median(np.hypot.reduce(v, axis=1)))
    if sph is None:
        return med, f"the median |{sym}|", med, None
    R = sph[1]
    if not on_shell(v, sph) and (shell_only or (plausible(med) and not plausible(R))):
        # (the accelerometer's readings also leave gravity's shell with a hand's acceleration: a VN-100 tumbled
        # through every direction, |a| 0.42-1.96 g, was said to have hardly turned)
        cause = ("the readings (a sensor that hardly turned, or one moved by hand: its acceleration moves the "
                 "readings off gravity's sphere)" if shell_only else
                 "their orientations (a sensor that hardly turned)")
        return med, (f"the median |{sym}|; the sphere through the readings, radius {R:.4g} {unit}, is not "
                     f"determined by {cause}"), med, None
    return R, "the radius of the sphere the readings lie on", med, sph


def _units_mag(ds, rows, rep):
    m = ds.mag[rows]
    F = ds.meta.get("field_nT")
    R, how, med, _ = _size(m, lambda b: _plausible_field(b, F), "b", "nT")
    fig = {"field_nT": R, "how": how, "median_abs_nT": med}
    if not (np.isfinite(R) and R > NO_SIZE):
        rep.findings.append(Finding("units", "error", (
            f"magnetometer: |b| is {R:.4g} nT ({how}): no field in the readings (a dead sensor, or the wrong "
            f"columns)"), "mag", fig))
        return
    unit = ds.meta.get("mag_unit", "nT")
    if _normalised(ds, R, F, how, unit, fig, rep):
        return
    if F:
        ratio = R / float(F)
        fig.update(header_field_nT=F, ratio=ratio)
        if FIELD_TOL[0] <= ratio <= FIELD_TOL[1]:
            return
        hint = _range_hint(ds, "mag", ratio)
        if _plausible_field(R, F):
            rep.findings.append(Finding("units", "warning", (
                f"magnetometer: |b| is {R:.4g} nT ({how}), {100 * (ratio - 1):+.0f} % from the header's field_nT "
                f"{F:g}: " + (f"{hint}, or a wrong field_nT" if hint else
                              "a magnetic disturbance near the bench, a wrong field_nT, or a scale error")),
                "mag", fig))
            return
        target = float(F)
    else:
        lo, hi = GEOMAGNETIC_NT
        if lo <= R <= hi:
            return
        if _plausible_field(R, None):
            rep.findings.append(Finding("units", "warning", (
                f"magnetometer: |b| is {R:.4g} nT ({how}), outside the geomagnetic range {lo:.0f}-{hi:.0f} nT: "
                f"steel or a magnet near the sensor, or a scale error; give # field_nT= if it is the site's "
                f"field"), "mag", fig))
            return
        target = 45_000.0
    hint = _range_hint(ds, "mag", R / target) if F else None  # without a header field no factor is exact
    rng = f"the header's field_nT {F:g}" if F else f"the geomagnetic range {GEOMAGNETIC_NT[0]:.0f}-" \
                                                   f"{GEOMAGNETIC_NT[1]:.0f} nT"
    if hint and _counts(ds, "mag"):  # counts: the lsb declared is the scale
        rep.findings.append(_lsb_error(ds, "mag", f"|b| is {R:.4g} nT ({how}), {R / target:.3g}x {rng}", hint, fig))
        return
    mid = _mid_scale_error(ds, "mag", m, fig)
    if mid is not None:
        rep.findings.append(mid)
        return
    guesses, counts = _unit_or_lsb(ds, "mag", m, R / target, MAG_UNIT_GUESS, "nT", 0.6, 0.2 if F else 0.6)
    magnet = _magnet_text(ds, R, F, guesses, counts)
    if magnet is not None:
        rep.findings.append(Finding("units", "error", (
            f"magnetometer: |b| is {R:.4g} nT ({how}), outside {rng}: {R / target:.3g}x "
            f"{'the header field' if F else 'a geomagnetic field'}, {magnet[0]}; "
            + _unit_fix(ds, "mag", guesses, counts, R / target).replace("fix the unit", "if it was logged away from them, fix the unit", 1)),
            "mag", {**fig, "looks_like": [], "magnet": magnet[1]}))
        return
    like = (f"the readings look like {' or '.join(guesses)}" if guesses else
            f"{R / target:.3g}x {'the header field' if F else 'a geomagnetic field'}" + (f": {hint}" if hint else "")
            + (f" ({counts})" if counts else ""))
    rep.findings.append(Finding("units", "error", (
        f"magnetometer: |b| is {R:.4g} nT ({how}), {'not' if F else 'outside'} {rng}: {like}, not {unit}; "
        + _unit_fix(ds, "mag", guesses, counts, R / target)), "mag",
        {**fig, "looks_like": guesses}))


def _normalised(ds, R: float, F, how: str, unit: str, fig: dict, rep) -> bool:
    """Readings normalised to the site's total field (|b| about 1: an Xsens
    MT Manager export's magnetometer in a.u., many public datasets) declared
    in a unit of field: |b| is 1 in the declared unit (within
    NORMALISED_TOL), which is no geomagnetic field in G, uT, nT or T (the
    earth's is 0.22-0.67 G), nor the header's field_nT.  Declared G on an
    Xsens log it had read "+102 % from the header's field_nT: the lsb or
    range setting looks 2x off"; an error naming unit = "field"."""
    size = _declared_factor(ds, "mag") if _imported(ds) else None
    if not size or abs(R / size - 1.0) > NORMALISED_TOL:
        return False
    if (FIELD_TOL[0] <= R / float(F) <= FIELD_TOL[1]) if F else GEOMAGNETIC_NT[0] <= R <= GEOMAGNETIC_NT[1]:
        return False
    site = (f"the header's field_nT is {float(F):g}" if F else
            f"a geomagnetic field is {GEOMAGNETIC_NT[0]:.0f}-{GEOMAGNETIC_NT[1]:.0f} nT")
    rep.findings.append(Finding("units", "error", (
        f"magnetometer: |b| is {R / size:.4g} {unit} ({how}), {R:.4g} nT, where {site}: 1 in the declared unit, "
        f"the readings look normalised to the site's total field (a.u., |b| about 1), not {unit}; fix the unit "
        f"(unit = \"field\", with the site's field: [header] field_nT) in the sensor description's "
        f"[magnetometer] and import again"), "mag", {**fig, "looks_like": ["field"], "logged_abs": R / size}))
    return True


def _other_units(triad: str, same) -> list:
    """The units of a triad's kind (a size each, not counts) other than the
    declared one, whose size is `same` (None: every one)."""
    from inclino.formats import sensor

    return [u for u in (("g", "m/s2", "mg") if triad == "acc" else ("uT", "G", "mG", "nT"))
            if same is None or abs(sensor.unit_size(u, triad) / same - 1.0) > 1e-9]


def _magnet_text(ds, R: float, F, guesses: list, counts: str):
    """(text, figures) for a field too strong for the site's that no unit
    explains, else None: |b| (a sphere's radius) beyond the geomagnetic
    range by GEOMAGNETIC_SLACK but within what a MEMS magnetometer reads
    (MAGNET_MAX_NT), in a unit that is a size (not counts), that no other
    unit of the kind brings within MAG_UNIT_TOL of a geomagnetic field (the
    guesses found none).  A unit slip is a power of ten (or 10^5); a field
    4x the earth's read in the declared unit is what a magnet or steel
    beside the sensor makes (ESPHome's HMC5883L under a wind vane's
    magnet, logged in uT as ESPHome gives it: 190 uT, was told "not uT",
    and the first unit named, mG, imported with a warning, every reading
    10x too small)."""
    from inclino.formats import sensor

    if F or guesses or counts or not GEOMAGNETIC_NT[1] * GEOMAGNETIC_SLACK < R <= MAGNET_MAX_NT:
        return None
    declared = str(ds.meta.get("mag_unit", "nT"))
    same = sensor.unit_size(declared, "mag")
    if same is None:
        return None
    nearest = None
    for u in _other_units("mag", same):
        x = R * sensor.unit_size(u, "mag") / same
        d = abs(math.log(x / 45_000.0))
        if nearest is None or d < nearest[0]:
            nearest = (d, u, x)
    if nearest is None or math.exp(nearest[0]) < MAG_UNIT_TOL:
        return None
    _, u, x = nearest
    return (f"and no other unit brings it to one ({u}, the nearest, reads {x:.4g} nT, {x / 45_000.0:.2g}x): "
            f"a magnet or steel near the sensor adds its own field (a wind vane's or a motor's magnet, a speaker, "
            f"a steel bracket), or a scale error; log the field away from them"), \
        {"nearest_unit": u, "nearest_nT": x}


def intended_reflection(ds, triad) -> bool:
    """Whether the dataset's header declares the triad's reflection
    intended (`# reflection=acc|mag`)."""
    return _listed(ds, "reflection", triad)


def _listed(ds, key: str, triad: str) -> bool:
    """Whether the header's comma-separated `key` names the triad."""
    return triad in str(ds.meta.get(key, "")).replace(" ", "").split(",")


def _axes_and_lag(ds, rows_all, rep, ug_src=None):
    """Inter-triad: the magnetometer's axes against the accelerometer's (or
    the poses' gravity) from the dip angle's consistency, then the row
    shift that makes it most consistent."""
    n = len(ds)
    block = np.arange(min(n, LAG_ROWS))  # consecutive rows (the lag needs neighbours)
    found = []

    def holds_found():
        from inclino import holds

        if not found:
            found.append(holds.find(ds))
        return found[0]

    def held():
        """The rows of `block` read at rest (holds.find, once) where there
        are enough holds to stand for the orientations, or None."""
        from inclino import holds

        h = holds_found()
        return h.labels[block] >= 0 if h.count >= holds.MIN_HOLDS else None
    G = float(ds.meta.get("gravity_g") or 1.0)
    if ug_src is None:
        ug, ok_g = _unit_dirs(ds.acc[block], G, held)
        other = "accelerometer's"
    else:
        ug, ok_g = ug_src[block], True
        other = "poses' gravity"
    F = float(ds.meta.get("field_nT") or 50_000.0)
    ub, ok_b = _unit_dirs(ds.mag[block], F, held)
    if len(block) < 6:
        return
    # raw directions (no ellipsoid: too few orientations) are only worth comparing when the offsets are
    # small against the vector: |v| nearly constant; or, where the rows moving between holds carry the hand's
    # acceleration, over the rows read at rest, and there also the size of the vector (at one orientation
    # |v| is constant whatever the offset): an NGIMU log of four holds at one orientation, 155 rows moved
    # between them, |a| varying by 36 %, had its turned gravity sign left unchecked against the header's dip
    for kind, ok, v, size in (("acc", ok_g, None if ug_src is not None else ds.acc[block], G),
                              ("mag", ok_b, ds.mag[block], F)):
        if not ok and v is not None:
            n = np.linalg.norm(v, axis=1)
            small = np.std(n) <= RAW_DIRS_MAX_CV * np.mean(n)
            rest = holds_found().labels[block] >= 0
            if not small and rest.sum() >= 6:
                n = n[rest]
                small = np.std(n) <= RAW_DIRS_MAX_CV * np.mean(n) \
                    and abs(np.median(n) / size - 1.0) <= RAW_DIRS_MAX_CV
            if not small:
                moved = None
                if kind == "acc":
                    from inclino import holds
                    from inclino.calib import motion

                    moved = motion.figures(ds)
                # a sensor swung by hand reads |a| far from 1 g on most rows: the hand's acceleration, not an
                # offset, keeps its raw directions from being gravity's (a VN-100 tumbled at 40 Hz, |a| 0.42-1.96 g,
                # its magnetometer's offsets 6 % of the field, was said to have "offsets too large")
                why = ("and the accelerometer's |g| as logged spreads {:.2g} g (robust 1 sigma, changing by {:.3g} mg "
                       "within {} rows): the hand's acceleration, so its raw directions are not gravity's".format(
                           moved["acc_norm_spread_g"], 1e3 * moved["acc_norm_jitter_g"], holds.HOLD_ROWS)
                       if moved is not None else "and offsets too large to compare raw directions")
                rep.findings.append(Finding("axes", "note", (
                    "the axes and the pairing of the triads were not checked"
                    + (", nor the gravity sign against the header's dip" if _dip_sign_known(ds) and ug_src is None
                       else "")
                    # (not "too few orientations" alone: an x-IMU shaken through every direction was said
                    # to have too few)
                    + ": no ellipsoid fits the readings (too few orientations, or a moving sensor's "
                      "acceleration), " + why), None, {}))
                return
    spreads, dips = {}, {}
    for P in signed_permutations():
        d = _dip(ug, ub @ P.T)
        spreads[tuple(P.ravel())] = _robust_std(d)
        dips[tuple(P.ravel())] = float(np.median(d))
    ident = tuple(np.eye(3).ravel())
    s_id = spreads[ident]
    s_min = min(spreads.values())
    # P and -P fit the dip equally well (with opposite signs): among the maps
    # as good as the best, the one with the header's dip sign, then the one
    # closest to the declared map (fewest axes changed), then a rotation
    hdr = ds.meta.get("dip_deg")
    tied = [k for k in spreads if spreads[k] <= 1.05 * s_min + 0.05]
    best = min(tied, key=lambda k: (0 if not _dip_sign_known(ds) or np.sign(dips[k]) == np.sign(float(hdr)) else 1,
                                    int(np.sum(np.any(np.array(k).reshape(3, 3) != np.eye(3), axis=1))),
                                    np.linalg.det(np.array(k).reshape(3, 3)) < 0))
    s_best = spreads[best]
    P = np.array(best).reshape(3, 3)
    # best_map: in the body frame as imported; map_to_write: composed with the declared map, what to write
    # in the description's [magnetometer] axes
    write, det_w = _map_to_write(ds, P)
    shown = f"axes = \"{write}\"" if _imported(ds) else write
    fig = {"dip_spread_declared_deg": s_id, "dip_spread_best_deg": s_best, "best_map": _perm_text(P),
           "map_to_write": write}
    # a map P and its negative -P spread the dip alike (the dip's sign turned), one a rotation of the axes as
    # given, the other a reflection: only the site's dip sign tells them apart
    reflected = intended_reflection(ds, "mag") or intended_reflection(ds, "acc")
    if best != ident and s_id > max(AXES_RATIO * s_best, MIN_SPREAD_DEG + s_best) and not _dip_sign_known(ds) \
            and not reflected:
        rep.findings.append(Finding("handedness", "error", _twins_text(
            ds, P, dips, other, f"the magnetometer's axes as given do not fit the {other}: the dip angle spreads "
                                f"{s_id:.3g} deg with the axes as given, {s_best:.3g} deg with")
            + "; " + (both + "; else " if (both := _both_reflected(ds)) else "")
            + _fix(ds, "magnetometer", "the axis map") + " (or give the site's dip to have it told)",
            "mag", {**fig, "twin_map_to_write": _map_to_write(ds, -P)[0]}))
        P = np.eye(3)
    elif best != ident and s_id > max(AXES_RATIO * s_best, MIN_SPREAD_DEG + s_best):
        det = int(round(np.linalg.det(P)))
        if det < 0:
            if not intended_reflection(ds, "mag") and not intended_reflection(ds, "acc"):
                if not _imported(ds):
                    fix = _fix(ds, "magnetometer", "the axis map (or reflection = true if the sensor's axes are "
                                                   "left-handed)")
                elif det_w < 0:
                    acc = ("the accelerometer's declared reflection ([accelerometer] reflection = true) does not fit "
                           "the data as mapped: fix that map" if declared_reflection(ds, "acc")
                           else "fix one sign of the accelerometer's map")
                    fix = (f"write that map in the sensor description's [magnetometer] with reflection = true (its "
                           f"axes as logged are left-handed against the {other}), or {acc}, and import again")
                else:
                    # a reflection declared in [magnetometer] composed with the mirror found: a rotation
                    fix = (f"the declared reflection ([magnetometer] reflection = true) does not fit the data as "
                           f"mapped: write that map, a rotation, without reflection = true in the sensor "
                           f"description's [magnetometer], or fix the accelerometer's map, and import again")
                    if both := _both_reflected(ds):
                        fix = (both + f"; writing magnetometer {shown} without its reflection "
                               f"instead would leave both triads mirrored alike, which the dip does not show and "
                               f"every azimuth would carry: fix the map that is wrong and import again")
                rep.findings.append(Finding("handedness", "error", (
                    f"the magnetometer's axes are mirrored against the {other}: the dip angle spreads "
                    f"{s_id:.3g} deg with the axes as given, {s_best:.3g} deg with magnetometer {shown} "
                    f"(a reflection of the axes as given, determinant -1): one triad's map has a sign or a swap "
                    f"wrong (without poses the data cannot tell which triad's): " + fix), "mag", fig))
        else:
            rep.findings.append(Finding("axes", "warning", (
                f"the magnetometer's axes are not the {other}: the dip angle spreads {s_id:.3g} deg with the "
                f"axes as given, {s_best:.3g} deg with magnetometer {shown} (a rotation; the fit "
                f"absorbs it, started from that map); "
                + _fix(ds, "magnetometer", "that axis map")), "mag", fig))
        rep.mag_to_acc = P.tolist()
    else:
        if ug_src is None and not rep.one_orientation:
            # with poses the fit is against the poses' field vectors, in which a mirrored axis leaves a
            # residual many times the noise (or a determinant -1): the dip alone is not all that checks it;
            # at one orientation nothing shows a mirror, which the orientations' note says
            _weak_handedness(ug, ub, spreads, dips, best, ident, other, ds, rep)
        P = np.eye(3)
    ubp = ub @ P.T
    m = len(block)
    held = _held(ds, block, ug, ub) if ug_src is None else None
    if held is not None:
        rep.findings.append(Finding("row-alignment", "note", held[0], None, held[1]))
    # one orientation: no position changes, a shift changes nothing (jitter at rest read as "rows where the
    # position changes" named a shift on a still log)
    lags = _spread_by_lag(ug, ubp) if held is None and not rep.one_orientation else {}
    if not lags:
        _dip_sign(ds, _dip(ug, ubp), ug_src, rep)
        return
    wide = _wide_lag(ug, ubp)
    if wide is not None and (wide[3]["wide_row_fixed"] or abs(wide[1]) > MAX_LAG + 1):
        # a shift beyond MAX_LAG rows (two files started apart, more than a lost line): named from the wider
        # search, where the narrower routes would name the edge of their range, a wrong lag; a shift one row
        # beyond it whose row the search does not fix is left to them (their edge is as near)
        route, kb, how, fig = wide
        sb = fig.pop("dip_spread_at_lag_deg")
        if "curve_lag_rows" in fig:  # the lag curve of the rows paired at the shift found, in rows as logged
            rep.lag_curve = {"lag_rows": fig["curve_lag_rows"], "se_rows": fig["curve_lag_se_rows"],
                             "halves_rows": fig["curve_lag_halves_rows"]}
        if fig["wide_row_fixed"]:
            _name_shift(ds, rep, route, kb, how, lags[0], sb, fig)
        else:
            edge = fig["wide_lag_rows"] == kb and abs(kb) == fig["wide_rows_searched"]  # the least at the edge
            fix = f"re-import with [magnetometer] lag = {_lag_to_write(ds, kb)} (the row or two left is then checked)"
            rep.findings.append(Finding("row-alignment", "warning", (
                f"the triads are paired out of step by "
                + (f"{kb:+d} rows or more (the edge of the shifts searched; " if edge else f"about {kb:+d} rows (")
                + f"the row not fixed: the dip changes "
                f"too little from one shift to the next here, or its spread is skewed by the triads' calibration "
                f"errors): {how}; {fix}"), None,
                {**fig, "lag_rows_about": kb, "lag_to_write": _lag_to_write(ds, kb), "fix": fix}))
        _dip_sign(ds, _dip(*_paired(ug, ubp, kb)), ug_src, rep)
        return
    fig = {"dip_spread_by_lag_deg": {str(k): v for k, v in lags.items()}}
    s0 = lags[0]

    def routes():
        """The shifts the routes name, in turn, each computed only when the one before it names none or its
        second view fails: (route, shift, spread there, evidence)."""
        if _spread_lag(lags, m):
            k = min(lags, key=lambda j: lags[j])
            yield "spread", k, lags[k], (f"the dip angle spreads {s0:.3g} deg as paired, {lags[k]:.3g} deg with "
                                         f"the magnetometer's rows shifted by {k:+d}")
        # a step-and-hold log of many rows per position: a shift mispairs only the rows where the
        # position changes, which the robust spread ignores; the mean deviation sees them
        kt, gain, t = _lag_transitions(ug, ubp)
        fig.update({"transition_lag_rows": kt, "transition_gain": gain, "transition_t": t})
        if _transitions_named(kt, gain, t):
            yield "transitions", kt, lags[kt], (
                f"the dip angle's mean deviation is {gain:.3g} times larger as paired than with the "
                f"magnetometer's rows shifted by {kt:+d} (the rows where the position changes are mispaired)")
        # a few positions (a six-face session with both triads): too few changes for the blocks' t, but
        # each change a shift mispairs reads a dip far off, and the right shift pairs every one of them
        # again without mispairing any other row
        kj, fixed, made = _lag_jumps(ug, ubp)
        fig.update({"jump_lag_rows": kj, "jump_rows_fixed": fixed, "jump_rows_made": made})
        if _jumps_named(kj, fixed, made):
            yield "jumps", kj, lags[kj], (
                f"{fixed} rows where the position changes read a dip far off as paired and in line with "
                f"the magnetometer's rows shifted by {kj:+d}" + (f" ({made} the other way)" if made else
                                                                 " (none the other way)"))

    # a continuously moving log: neighbouring rows are close orientations, so a shift of a row or two
    # changes the dip's spread by a few % only; the lag curve of the invariant, with the triads'
    # calibration errors and a turning lever arm's acceleration fitted out, locates the pairing to a fraction
    # of a row
    inv = _lag_curve(ug, ubp)
    short = None if inv is not None else _lag_curve(ug, ubp, min_rows=LAG_CURVE_SHORT_ROWS, refit=True)
    if short is not None and (_short_curve_names(short["lag"], short["se"], short["halves"]) or _in_step(short)):
        # a curve on fewer than LAG_CURVE_ROWS rows that names its row beyond doubt, or puts the rows in step
        # (the other routes' shifts then stand its second view: on independently simulated smooth tumbles of
        # 300 rows in step the spread named -1, the curve -0.02 +- 0.13)
        inv = short
    curve = rule = k = None
    beyond = False
    if inv is not None:
        rep.lag_curve = {"lag_rows": inv["lag"], "se_rows": inv["se"], "halves_rows": inv["halves"]}
        fig.update({"curve_lag_rows": inv["lag"], "curve_lag_se_rows": inv["se"],
                    "curve_lag_halves_rows": inv["halves"]})
        rule, k = _curve_rule(inv["lag"], inv["se"], inv["halves"])
        if rule == "curve" and k not in lags and _curve_in_step(*_paired(ug, ubp, k)):
            # the curve's row beyond the shifts the spread tried (its vertex taken from the trials at the
            # edge), and the curve of the rows paired at that row puts them in step: named as any other
            lags[k] = _robust_std(_dip(*_paired(ug, ubp, k)))
        # the curve's row beyond the shifts the spread tried, by more than its standard error
        beyond = rule is not None and k not in lags and abs(inv["lag"]) - MAX_LAG > inv["se"]
        if k not in lags:
            rule = None
        halves_txt = ", ".join("too short to tell" if h is None else f"{h:+.2f}" for h in inv["halves"])
        if rule == "curve":
            curve = ("curve", k, (
                f"with the triads' calibration errors and a turning lever arm's acceleration fitted out, the dip "
                f"angle is most consistent with the magnetometer's rows shifted by {inv['lag']:+.2f} +- "
                f"{_se_text(inv['se'])} (each half of the log on its own: {halves_txt})"))
        elif rule == "nearest":
            # the nearest whole row pairs the rows better than the rows as logged, but a log with a skew of its
            # own of nearly half a row reads like this too: named, as a warning that says so
            curve = ("nearest", k, (
                f"with the triads' calibration errors and a turning lever arm's acceleration fitted out, the dip "
                f"angle is most consistent with the magnetometer's rows shifted by {inv['lag']:+.2f} +- "
                f"{_se_text(inv['se'])} (each half of the log on its own: {halves_txt}), nearest whole row {k:+d}; "
                f"within {LAG_CURVE_SE:g} standard errors of half a row, so a skew of the log's own between the "
                f"sensors' sampling is not ruled out (a lag of {k:+d} then leaves {inv['lag'] - k:+.2f} rows against "
                f"{inv['lag']:+.2f} as logged: it pairs the rows better either way; a session held still at each "
                f"position tells the two apart)"))

    # each route's shift must stand a second view before it is named; one that does not is a note (the first
    # such, when no later route names a shift that stands it: on six stops turned between over ten rows, the
    # spread, skewed by the stops' calibration errors, found -2 with halves -3 and -1, the count -1 with every
    # change paired again and none mispaired)
    route, doubt = None, None
    for route, kb, sb, how in routes():
        rfig = dict(fig)
        why = None  # why the route's shift is not named ("": nothing to say of it)
        if inv is not None and round(inv["lag"]) != kb:
            # a continuously moving log: the dip's raw spread (the triads' calibration errors left in) is itself
            # skewed along the shift (on the clean CK log its least value sits 1 to 2 rows off in stretches of
            # 4 000 rows), so a shift it finds is named only where the calibrated curve puts the pairing too (and
            # where the curve puts the rows in step, nothing is said of it: on a simulated hand tumble in step at
            # 100 rows/s the jumps' count found 31 rows "in line with +3", the curve -0.04 +- 0.05)
            why = "" if _in_step(inv) else (
                f"the dip invariant's lag curve, with the triads' calibration errors and a turning lever arm's "
                f"acceleration fitted out, puts the magnetometer's rows {inv['lag']:+.2f} +- {inv['se']:.2f} out of "
                f"step (nearest row {int(round(inv['lag'])):+d})")
        elif inv is None and short is not None and abs(short["lag"] - kb) - 0.5 > LAG_CURVE_SE * short["se"]:
            # a curve of fewer than LAG_CURVE_ROWS rows that names no row still rules out a shift it lies
            # LAG_CURVE_SE standard errors beyond half a row from (a smooth tumble of 600 rows a row behind, its
            # curve at +0.87 +- 0.16, had the spread name +2)
            why = (f"the dip invariant's lag curve, with the triads' calibration errors and a turning lever arm's "
                   f"acceleration fitted out, puts the magnetometer's rows {short['lag']:+.2f} +- "
                   f"{_se_text(short['se'])} out of step, more than {LAG_CURVE_SE:g} standard errors beyond half a "
                   f"row from {kb:+d}")
        else:
            # a second view: each half of the log on its own must find the same shift (a half too short to
            # tell is no objection)
            h = m // 2
            halves = [_route_lag(route, ug[sl], ubp[sl]) for sl in (slice(0, h), slice(h, m))]
            rfig["halves_lag_rows"] = halves
            if any(x is not None and x != kb for x in halves):
                if curve is not None and curve[1] == kb:
                    # the raw spread's halves disagree (each half's spread is skewed by the calibration errors it
                    # leaves in), but the lag curve, whose halves agree on the side, puts the pairing at that row
                    route, kb, how = curve
                    fig = rfig
                    break
                why = (f"the two halves of the log find "
                       f"{' and '.join('no shift' if x == 0 else f'{x:+d}' for x in halves if x is not None)}")
            elif route == "spread" and all(x is None for x in halves) and not _stands_out(lags, kb):
                # no half can tell (a log of a dozen rows: SAP6's BB, 24 shots, with 12 of them lost at the start
                # of one file, read -3)
                why = (f"on too few rows for each half of the log to tell, and the dip spreads less than "
                       f"{LAG_RATIO:g} times as much at other shifts")
        if why is None:
            fig = rfig
            break
        if why and doubt is None:
            doubt = Finding("row-alignment", "note", f"the triads may be paired out of step ({how}), but {why}: not "
                            f"named", None, {**rfig, "lag_rows": kb})
        route = None
    gyro = _gyro_shift(ds, block, ug, ubp) if route is None and ug_src is None else None
    if gyro is not None and gyro[0] != 0 and abs(gyro[0]) <= MAX_LAG and not (inv is not None and curve is not None):
        # no dip route or lag curve names a shift (a log turned mostly about the vertical or magnetic north leaves
        # the dip alone), but each triad's turning against the gyroscope's rate fixes its row
        kb, gfig = gyro
        route, sb = "gyroscope", lags.get(kb)
        if sb is None:
            sb = _robust_std(_dip(*_paired(ug, ubp, kb)))
        fig = {**fig, **gfig}
        how = (f"turned by the gyroscope's rate, the accelerometer's rows follow it with a lag of "
               f"{gfig['gyro_lag_acc_rows']:+d}, the magnetometer's with {gfig['gyro_lag_mag_rows']:+d} (each half of "
               f"the log alike, each lag's fit better than at the rows beside it by "
               f"{100 * (1 - max(gfig['gyro_sharpness_acc'] + gfig['gyro_sharpness_mag'])):.0f} % or more)")
    if route is None and doubt is not None and not (inv is not None and curve is not None):
        # (a route's doubt is not said beside the shift the lag curve then names: GyroLib's log, its
        # magnetometer two rows ahead, was told "+3 ... not named" and "-2 ... re-import with lag")
        rep.findings.append(doubt)
    if inv is not None:
        if route is None and curve is not None:
            route, kb, how = curve
            sb = lags[kb]
        elif route is None and k == 0 and abs(inv["lag"]) > max(0.25, LAG_CURVE_SE * inv["se"]):
            rep.findings.append(Finding("row-alignment", "note", (
                f"the triads look sampled {inv['lag']:+.2f} +- {_se_text(inv['se'])} rows apart (the magnetometer's "
                f"rows shifted by that fraction make the dip most consistent): a skew between the two "
                f"sensors' sampling within a row, not a lost line; no whole-row lag fixes it"), None,
                {"curve_lag_rows": inv["lag"], "curve_lag_se_rows": inv["se"]}))
        elif route is None and beyond:
            rep.findings.append(Finding("row-alignment", "note", (
                f"the dip invariant's lag curve puts the magnetometer's rows {inv['lag']:+.2f} +- "
                f"{_se_text(inv['se'])} out of step (each half of the log: {halves_txt}), beyond the {MAX_LAG} rows "
                f"either way the other checks try, and the dip's spread does not find it further out: a shift of "
                f"about {k:+d} is possible, not named"),
                None, {"curve_lag_rows": inv["lag"], "curve_lag_se_rows": inv["se"], "lag_rows_possible": k}))
        elif route is None and rule is not None:
            rep.findings.append(_possible_shift(
                inv, k, f"the curve's scatter is more than {LAG_CURVE_NEAREST_SE:g} row"))
    if route is None and inv is None and short is not None and doubt is None:
        # a curve of fewer than LAG_CURVE_ROWS rows, not sure of its row: what it reads, said as a note (timspi's
        # log of 1 252 rows a row ahead reads -1.40 +- 0.64, halves -1.34 and -1.69)
        rule_s, ks = _curve_rule(short["lag"], short["se"], short["halves"])
        if rule_s is not None and short["se"] < LAG_CURVE_POSSIBLE_SE:
            rep.findings.append(_possible_shift(short, ks, _short_rule_text()))
    if route is not None:
        if inv is not None and route not in ("curve", "nearest", "gyroscope"):
            how += f"; the lag curve puts it at {inv['lag']:+.2f} +- {_se_text(inv['se'])} rows"
        if inv is not None and route not in ("nearest", "gyroscope") and abs(inv["lag"] - kb) > 0.25 and abs(inv["lag"] - kb) > LAG_CURVE_SE * inv["se"]:
            how += (f" (a whole-row lag leaves {inv['lag'] - kb:+.2f} rows: a skew between the sensors' sampling "
                    f"that no lag removes)")
        _name_shift(ds, rep, route, kb, how, s0, sb, fig)
    elif ug_src is None and not any(f.check == "row-alignment" for f in rep.findings) and \
            not (gyro is not None and gyro[0] == 0):
        # (each triad's row fixed against the gyroscope and the two in step: the pairing is checked)
        from inclino import holds as _holds

        h = holds_found()
        unseen = None if rep.one_orientation else _shifts_unseen(
            ug, ubp, inv or short, lags, strict=inv is None or inv is short,
            held=(h.count, h.rows_moving) if h.count >= _holds.MIN_HOLDS else None)
        if unseen:
            rep.findings.append(Finding("row-alignment", "note", unseen[0], None, unseen[1]))
    _dip_sign(ds, _dip(*_paired(ug, ubp, rep.lag_rows or 0)), ug_src, rep)  # the dip's sign, as named paired


def _gyro_fits(u, w, dt, K: int = MAX_LAG) -> dict:
    """{lag: (residual share, coefficient)}: the triad's unit directions u
    turned by the gyroscope's rate w (any unit: the coefficient takes the
    unit and the step dt), row by row: u[i+1+L] - u[i+L] fitted on
    -(w x u) dt with the rate of rows i, i+1 averaged (a body-frame vector
    in a still field turns against the body's rate), both summed over
    GYRO_LAG_SMOOTH_ROWS rows, for the triad's row
    i + L read with the gyroscope's row i; the residual as a share of the
    differences' sum of squares."""
    n = len(u)
    i = np.arange(K, n - K - 1)
    turn = 0.5 * (w[i] + w[i + 1]) * dt[i, None]
    out = {}

    def summed(a):
        c = np.cumsum(np.vstack([np.zeros((1, 3)), a]), axis=0)
        return c[GYRO_LAG_SMOOTH_ROWS:] - c[:-GYRO_LAG_SMOOTH_ROWS]
    for L in range(-K, K + 1):
        d = summed(u[i + 1 + L] - u[i + L])
        x = summed(-np.cross(turn, 0.5 * (u[i + L] + u[i + 1 + L])))
        xx, dd = float((x * x).sum()), float((d * d).sum())
        if not (xx > 0 and dd > 0):
            return {}
        c = float((d * x).sum()) / xx
        out[L] = (float(((d - c * x) ** 2).sum()) / dd, c)
    return out


def _gyro_lag(u, w, dt) -> tuple:
    """(lag, sharpness per half) of a triad against the gyroscope: the lag
    whose fit (_gyro_fits) leaves the least residual on the whole log, or
    None unless each half of the log finds the same lag with a positive
    coefficient and a residual below GYRO_LAG_SHARP times the residual at
    either neighbouring lag (sharpness: that ratio per half)."""
    n = len(u)
    h = n // 2
    lags, ratios = [], []
    for sl in (slice(0, n), slice(0, h), slice(h, n)):
        f = _gyro_fits(u[sl], w[sl], dt[sl])
        if not f:
            return None, []
        best = min(f, key=lambda k: f[k][0])
        near = min(f[k][0] for k in (best - 1, best + 1) if k in f)
        lags.append(best if f[best][1] > 0 and best - 1 in f and best + 1 in f else None)
        ratios.append(f[best][0] / near if near > 0 else 1.0)
    sharp = all(x is not None and x == lags[0] for x in lags) and max(ratios[1:]) < GYRO_LAG_SHARP
    return (lags[0] if sharp else None), ratios[1:]


def _gyro_shift(ds, block, ug, ubp):
    """The triads' shift from each one's lag against the gyroscope (a
    dataset with wx_dps, wy_dps, wz_dps): the magnetometer's lag less the
    accelerometer's, found on any turn but one about the triad's own vector
    (the dip invariant sees only turns about magnetic east-west).  None
    without a gyroscope or when either lag is not sharp; else (shift,
    figures)."""
    if not ds.has_gyro or len(block) < GYRO_LAG_MIN_ROWS:
        return None
    w = ds.gyro[block]
    t = ds.columns.get("t_s")
    dt = np.ones(len(block))
    if t is not None:
        step = np.diff(t[block])
        if np.all(np.isfinite(step)) and np.all(step > 0):
            dt = np.append(step, np.median(step))
    la, ra = _gyro_lag(ug, w, dt)
    lm, rm = _gyro_lag(ubp, w, dt)
    fig = {"gyro_lag_acc_rows": la, "gyro_lag_mag_rows": lm, "gyro_sharpness_acc": ra, "gyro_sharpness_mag": rm}
    if la is None or lm is None:
        return None
    return lm - la, fig


def _name_shift(ds, rep, route: str, kb: int, how: str, s0: float, sb: float, fig: dict) -> None:
    """The row-alignment finding for a shift kb a route named (how: the
    evidence; s0, sb: the dip's spread as paired and at kb), with the lag
    to write in the sensor description; sets rep.lag_rows."""
    level = "error" if route != "nearest" and s0 > LAG_RATIO * sb and s0 > 2.0 else "warning"
    which = "behind" if kb > 0 else "ahead of"
    rep.lag_rows = kb
    lag = _lag_to_write(ds, kb)  # the declared lag plus the shift found in the data as imported
    if not _imported(ds):
        fix = f"shift the magnetometer columns by {kb} row(s) (inclino import with [magnetometer] lag = {kb})"
    elif lag == kb:
        fix = f"re-import with [magnetometer] lag = {kb}"
    elif lag == 0:
        fix = (f"re-import with [magnetometer] lag = 0 (remove the declared lag of {lag - kb}: it shifts the "
               f"rows {-kb:+d})")
    else:
        fix = (f"re-import with [magnetometer] lag = {lag} (the declared lag of {lag - kb} and the {kb:+d} "
               f"found in the rows as imported)")
    lost = "a line is lost" if abs(kb) == 1 else f"{abs(kb)} lines are lost, or one file starts later"
    # the spread at the shifts beside it within LAG_NEIGHBOUR of its own: the row is not fixed (a log of 1 252
    # rows shifted by 3 had its spread 3.48 deg at +2, 3.57 at +3, and "lag = 2" was named as the lag)
    spreads = fig.get("dip_spread_by_lag_deg") or {}
    near = [k for k in (kb - 1, kb + 1) if route == "spread" and str(k) in spreads
            and spreads[str(k)] <= (1.0 + LAG_NEIGHBOUR) * sb]
    unfixed = ("" if not near else
               f"; the row is not fixed: the spread at {' and '.join(f'{k:+d}' for k in near)} is within "
               f"{100 * LAG_NEIGHBOUR:.0f} % of it (lag = {' or '.join(str(lag + k - kb) for k in near)} fits nearly as "
               f"well)")
    rep.findings.append(Finding("row-alignment", level, (
        f"the triads {'look' if route == 'nearest' else 'are'} paired out of step: {how} (its row i "
        f"{'+' if kb > 0 else '-'} {abs(kb)} belongs to the accelerometer's row i: one {which} the other, as when "
        f"two files are joined and {lost}); " + fix + unfixed),
        None, {**fig, "lag_rows": kb, "lag_to_write": lag, "route": route, "lags_as_near": near, "fix": fix}))


def _held(ds, block, ug, ub):
    """A triad sampled slower than the other and repeated between its
    updates (sample and hold: x-io's Fusion example logs its magnetometer
    at a fifth of the accelerometer's rate, 80 % of its rows a copy of the
    row before): each held reading is paired with accelerometer rows up to
    a hold later than it was read, so the dip's lag curve sits at the hold's
    mean age on the log as logged (+2 rows on Fusion's) and a whole-row
    shift is not what the rows show.  (message, figures) or None."""
    rep_frac = {}
    for t in ("acc", "mag"):
        v = getattr(ds, t)[block]
        rep_frac[t] = float(np.mean(np.all(np.diff(v, axis=0) == 0, axis=1))) if len(v) > 1 else 0.0
    slow = max(rep_frac, key=rep_frac.get)
    fast = "acc" if slow == "mag" else "mag"
    if not (rep_frac[slow] >= HELD_FRAC and rep_frac[fast] < HELD_OTHER):
        return None
    if max(np.linalg.norm(ug.mean(0)), np.linalg.norm(ub.mean(0))) > LAG_CURVE_MAX_RESULTANT:
        return None  # a log that hardly turns: the repeats are a quantised reading at rest, not a hold
    every = 1.0 / max(1.0 - rep_frac[slow], 1e-9)
    name = {"acc": "accelerometer", "mag": "magnetometer"}
    return (f"the pairing of the triads cannot be checked to a row on this log: the {name[slow]} repeats its "
            f"previous reading on {100 * rep_frac[slow]:.0f} % of the rows (a slower sensor held between its "
            f"updates, a new reading every {every:.1f} rows), so each of its readings is paired with "
            f"{name[fast]} rows up to {every:.1f} rows younger; a lag of a row or two is not named"), \
        {"held_triad": slow, "repeat_fraction": rep_frac[slow], "rows_per_update": every}


def _dip_sign(ds, d, ug_src, rep):
    """The dip's sign against the header's (a turned gravity sign), or a
    note that it cannot be checked."""
    dip = float(np.median(d))
    rep.noise["dip_deg"] = dip
    hdr = ds.meta.get("dip_deg")
    if hdr is None and ug_src is None and abs(dip) > DIP_SIGN_MIN_DEG:
        rep.findings.append(Finding("dip-sign", "note", (
            f"the accelerometer's gravity sign was not checked: the dip angle is {dip:+.1f} deg, and a turned sign "
            f"(reads = \"up\" or \"down\") only turns it to {-dip:+.1f} deg, a site in the other magnetic hemisphere; "
            f"give the site's dip ([header] dip_deg, or # dip_deg= in the log; inclino reffield) to have it checked"),
            "acc", {"dip_deg": dip}))
    if hdr is not None and ug_src is None:
        hdr = float(hdr)
        if abs(hdr) > DIP_SIGN_MIN_DEG and np.sign(dip) != np.sign(hdr) \
                and abs(dip + hdr) < max(DIP_MISMATCH_DEG, 0.3 * abs(hdr)):
            if _mirror_turns_dip(ds, dip, hdr, rep):
                return
            rep.findings.append(Finding("dip-sign", "error", (
                f"the dip angle is {dip:+.1f} deg against the header's {hdr:+.1f}: the accelerometer's gravity sign "
                f"is turned (an axis pointing down must read +1 g: reads = \"up\" or \"down\"), or every "
                f"magnetometer axis is reversed; "
                + _fix(ds, "accelerometer", "reads")), "acc", {"dip_deg": dip, "header_dip_deg": hdr}))
        elif abs(dip - hdr) > DIP_MISMATCH_DEG:
            spread = _robust_std(d)
            # a dip that scatters by tens of degrees from row to row: the rows may be paired out of step by more
            # than the shifts searched (a log of 30 positions shifted by 20 rows, searched to 18)
            paired = (f", or the triads paired out of step by more rows than were searched (the dip spreads "
                      f"{spread:.3g} deg from row to row)" if spread > DIP_MISMATCH_DEG and not rep.lag_rows else "")
            rep.findings.append(Finding("dip-sign", "warning", (
                f"the dip angle is {dip:+.1f} deg (median, before calibration: each triad corrected by an "
                f"ellipsoid fitted to its own readings, not the raw readings) against the header's {hdr:+.1f}: a "
                f"wrong dip_deg, a disturbed field, or a large misalignment{paired}"), None,
                {"dip_deg": dip, "header_dip_deg": hdr, "dip_spread_deg": spread}))


def _mirror_turns_dip(ds, dip: float, hdr: float, rep) -> bool:
    """Where the dip's sign is the header's turned and the weak handedness
    check (_weak_handedness) found a reflection that gives the header's sign
    and cuts the dip's spread: the mirror named as the error, in place of its
    warning and of a turned gravity sign, which turns the dip alone and
    leaves its spread (x-io's Fusion example, held nearly flat, its
    magnetometer's z reversed: the dip -69.1 deg against +66.3, spreading
    2.90 deg; with z reversed back +69.2, 1.21 deg; the gravity sign was
    named, and its fix imported every inclination as 180 - inc).  True when
    it named the mirror."""
    w = next((f for f in rep.findings if f.check == "handedness" and f.level == "warning" and f.triad == "mag"
              and "best_map_dip_deg" in f.figures), None)
    if w is None or np.sign(w.figures["best_map_dip_deg"]) != np.sign(hdr):
        return False
    fg = w.figures
    rep.findings.remove(w)
    shown = f"axes = \"{fg['map_to_write']}\"" if _imported(ds) else fg["map_to_write"]
    rep.findings.append(Finding("handedness", "error", (
        f"the dip angle is {dip:+.1f} deg against the header's {hdr:+.1f}, and {fg['best_map_dip_deg']:+.1f} deg "
        f"with magnetometer {shown}, which cuts its spread from {fg['dip_spread_declared_deg']:.3g} to "
        f"{fg['dip_spread_best_deg']:.3g} deg (a turned gravity sign would turn the dip and leave its spread): one "
        f"triad's axis mirrored against the other's, not the gravity sign; fix the map of the triad that is wrong "
        f"(the magnetometer's so, or the same axis of the accelerometer's: without poses the data cannot tell "
        f"which) and import again"), "mag",
        {**fg, "dip_deg": dip, "header_dip_deg": hdr}))
    return True


def _both_reflected(ds) -> str:
    """Where both triads' maps are declared reflections and the data find
    them mirrored against each other, the advice to check the
    accelerometer's first (an LSM9DS1, its magnetometer left-handed as
    declared, its accelerometer's z mirrored and declared a reflection too,
    was told to drop the magnetometer's reflection first, which leaves both
    triads mirrored alike: the dip does not show it, every azimuth carries
    it); "" otherwise."""
    if not (declared_reflection(ds, "acc") and declared_reflection(ds, "mag")):
        return ""
    return ("both triads declare a reflection ([accelerometer] and [magnetometer] reflection = true) and the data "
            "say one of them is wrong: check the accelerometer's map first (MEMS accelerometers' axes are "
            "right-handed on their data sheets; a left-handed triad is usually a combination part's magnetometer, "
            "as the LSM9DS1's)")


def _dip_sign_known(ds) -> bool:
    """Whether the header gives the site's dip far enough from 0 (beyond
    DIP_SIGN_MIN_DEG) for its sign to tell a map from its negative."""
    hdr = ds.meta.get("dip_deg")
    return hdr is not None and abs(float(hdr)) >= DIP_SIGN_MIN_DEG


def _twins_text(ds, P, dips, other, head) -> str:
    """`head` followed by the two maps that spread the dip alike, P and -P
    (found in the body frame as imported; written composed with the
    declared map, one right-handed, one left-handed, their dips of opposite
    signs), and why the data do not choose: an ICM-20948's magnetometer map
    written turned 180 deg about z was called mirrored, and its advised
    reflection imported with every azimuth 180 deg off."""
    def one(M):
        write, det = _map_to_write(ds, M)
        shown = f"axes = \"{write}\"" if _imported(ds) else write
        hand = ("right-handed" if det > 0 else
                "left-handed, with reflection = true" if _imported(ds) else "a reflection, determinant -1")
        return f"magnetometer {shown} ({hand}: dip {dips[tuple(M.ravel())]:+.1f} deg)", det
    (a, da), (b, _) = one(P), one(-P)
    if da < 0:
        a, b = b, a
    return (f"{head} either {a} or {b}: the two fit the {other} alike, the dip's sign turned, and only the "
            f"site's dip tells them apart (without a header dip_deg the checks cannot; [header] dip_deg, or "
            f"# dip_deg= in the log; inclino reffield gives it)")


def _weak_handedness(ug, ub, spreads, dips, best, ident, other, ds, rep):
    """Where no map cuts the dip's spread AXES_RATIO times: how well the data
    tell a mirrored magnetometer axis at all.  A one-axis mirror moves the dip
    only where that axis and gravity (or the field) share a plane the sensor
    turns through: a sensor held nearly flat and turned about the vertical
    (a hand-held IMU on a desk: x-io's Fusion example, the dip spreading 1.22
    deg as logged, 1.56 with y mirrored) cannot tell, and a mirrored axis then
    passed in silence.  A reflection that cuts the spread HAND_WEAK_RATIO
    times (and HAND_WEAK_DEG), in each half of the log on its own too, is a
    warning; a declared map that beats every one-axis mirror by less than
    HAND_NOTE_RATIO is a note: the handedness was checked on too little."""
    if intended_reflection(ds, "mag") or intended_reflection(ds, "acc"):
        return
    s_id = spreads[ident]
    P = np.array(best).reshape(3, 3)
    m = len(ug)
    write = _map_to_write(ds, P)[0]
    shown = f"axes = \"{write}\"" if _imported(ds) else write
    if best != ident and np.linalg.det(P) < 0 and s_id > HAND_WEAK_RATIO * spreads[best] \
            and s_id - spreads[best] > HAND_WEAK_DEG and m >= 40:
        h = m // 2
        halves = [(_robust_std(_dip(ug[sl], ub[sl])), _robust_std(_dip(ug[sl], ub[sl] @ P.T)))
                  for sl in (slice(0, h), slice(h, m))]
        if all(a > HAND_WEAK_HALF * b for a, b in halves):
            fig = {"dip_spread_declared_deg": s_id, "dip_spread_best_deg": spreads[best], "best_map": _perm_text(P),
                   "map_to_write": write, "halves_deg": halves, "best_map_dip_deg": dips[best]}
            weak = (f"; the sensor turned through too few orientations to be sure (the error needs {AXES_RATIO:g}x): "
                    f"check the axis map of each triad against its data sheet, or log the sensor tilted through more "
                    f"orientations")
            if not _dip_sign_known(ds):
                # the mirror found and its negative, a rotation of the axes as given, spread the dip alike: both
                text = _twins_text(ds, P, dips, other, (
                    f"the magnetometer's axes as given may not fit the {other}: the dip angle spreads {s_id:.3g} deg "
                    f"with the axes as given ({', '.join(f'{a:.3g}' for a, _ in halves)} in each half of the log), "
                    f"{spreads[best]:.3g} deg ({', '.join(f'{b:.3g}' for _, b in halves)}) with"))
                fig["twin_map_to_write"] = _map_to_write(ds, -P)[0]
            else:
                text = (f"the magnetometer's axes may be mirrored against the {other}: the dip angle spreads "
                        f"{s_id:.3g} deg with the axes as given, {spreads[best]:.3g} deg with magnetometer {shown} (a "
                        f"reflection, the dip's sign the header's; each half of the log: "
                        f"{', '.join(f'{a:.3g} against {b:.3g}' for a, b in halves)})")
            if declared_reflection(ds, "acc") and not declared_reflection(ds, "mag"):
                # the mirror the dip finds may be the accelerometer's declared one (x-io's Fusion log, its
                # accelerometer written x = -ax with reflection = true, was told to mirror the magnetometer too)
                weak += ("; the accelerometer's declared reflection ([accelerometer] reflection = true) would do "
                         "this: MEMS accelerometers' axes are right-handed on their data sheets, check that map first")
            rep.findings.append(Finding("handedness", "warning", text + weak, "mag", fig))
            return
    mirrors = {a: spreads[tuple(np.diag([-1.0 if j == a else 1.0 for j in range(3)]).ravel())] for a in range(3)}
    a = min(mirrors, key=mirrors.get)
    if s_id > 0 and mirrors[a] < HAND_NOTE_RATIO * s_id:
        from inclino.calib import motion

        moved = motion.figures(ds) if getattr(ds, "has_acc", False) else None
        # a sensor turned through the sphere by hand tilts enough; the hand's acceleration, in every row, scatters
        # the dip more than a mirror changes it (an iPhone turned through every octant, |g| spread 0.05 g, was said
        # to hardly tilt)
        tilts = moved is not None and moved["direction_cond"] <= motion.PLENTY_COND
        why = (f"the sensor moved while it was read ({100 * moved['moving_share']:.0f} % of the rows; |g| as logged "
               f"spreads {moved['acc_norm_spread_g']:.2g} g): the hand's acceleration scatters the dip as much as a "
               f"mirrored axis would change it" if tilts else
               "the sensor hardly tilts through the orientations that would show a mirrored axis")
        rep.findings.append(Finding("handedness", "note", (
            f"the handedness of the triads was checked on too little: the dip angle spreads {s_id:.3g} deg with the "
            f"axes as given, {mirrors[a]:.3g} deg with the magnetometer's {'xyz'[a]} axis mirrored (an error needs "
            f"{AXES_RATIO:g}x): {why}; a mirrored axis may pass unnamed"), None, {"dip_spread_declared_deg": s_id,
                                                        "dip_spread_mirrored_deg": {'xyz'[k]: v for k, v in mirrors.items()}}))


def _spread_by_lag(ug, ub, K: int = MAX_LAG) -> dict:
    """{k: robust spread of the dip (deg)} with the magnetometer's row i + k
    paired with the accelerometer's row i, k = -K..K (MAX_LAG)."""
    m = len(ug)
    out = {}
    for k in range(-K, K + 1):
        if m - abs(k) < 6:
            continue
        out[k] = _robust_std(_dip(*_paired(ug, ub, k)))
    return out


def _route_lag(route, ug, ub):
    """The shift a route finds on part of a log (None: too short to tell)."""
    if route == "spread":
        lags = _spread_by_lag(ug, ub)
        return min(lags, key=lambda k: lags[k]) if 0 in lags and len(lags) == 2 * MAX_LAG + 1 else None
    if route == "jumps":
        k, fixed, made = _lag_jumps(ug, ub)
        return k if _jumps_named(k, fixed, made) else None
    if len(ug) < max(80, 4 * MAX_LAG + 40):  # _lag_transitions: 8 blocks of 10 rows
        return None
    return _lag_transitions(ug, ub)[0]


def _lag_transitions(ug, ub, K: int = MAX_LAG):
    """(best shift, gain, t) from the mean absolute deviation of the dip,
    paired row by row against the rows as logged: the same accelerometer
    rows at every shift -K..K (MAX_LAG), the rows' differences averaged in
    blocks (neighbours are not independent), t = the blocks' mean over its
    standard error."""
    if len(ug) < 4 * K + 40:
        return 0, 1.0, 0.0
    dev = _deviations(ug, ub, K)
    mean = {k: float(np.mean(v)) for k, v in dev.items()}
    kb = min(mean, key=mean.get)
    if kb == 0 or not mean[kb] > 0:
        return 0, 1.0, 0.0
    nb, t = _block_t(dev[0] - dev[kb])
    if nb < 8:
        return 0, 1.0, 0.0
    return kb, mean[0] / mean[kb], t


def _deviations(ug, ub, K: int) -> dict:
    """{k: |dip - its median|} row by row, the magnetometer's row i + k with
    the accelerometer's row i, the same accelerometer rows K .. m - K - 1 at
    every shift k = -K..K."""
    i = np.arange(K, len(ug) - K)
    out = {}
    for k in range(-K, K + 1):
        d = _dip(ug[i], ub[i + k])
        out[k] = np.abs(d - np.median(d))
    return out


def _block_t(diff) -> tuple:
    """(blocks, t): per-row differences averaged in blocks of at least 10
    consecutive rows (neighbours are not independent), t = the blocks' mean
    over its standard error."""
    L = max(10, len(diff) // 200)
    nb = len(diff) // L
    bm = diff[:nb * L].reshape(nb, L).mean(1)
    se = float(np.std(bm, ddof=1) / math.sqrt(nb)) if nb > 1 else 0.0
    return nb, (float(np.mean(bm) / se) if se > 0 else float("inf"))


def _stands_out(spreads: dict, k: int) -> bool:
    """Whether the dip spreads LAG_RATIO times less at shift k than at every
    shift but its neighbours ({shift: spread}): the second view of a shift
    where no half of the log can tell, for the least of many spreads of a
    few rows each is low by chance."""
    rest = [v for j, v in spreads.items() if abs(j - k) > 1]
    return bool(rest) and LAG_RATIO * spreads[k] < min(rest)


def _spread_lag(lags: dict, m: int) -> int:
    """The shift the dip's spread names (0: none): the best shift cuts the
    spread by more than its own relative precision, about 1/sqrt(2n), many
    times over (and LAG_MIN_GAIN, and LAG_MIN_DEG)."""
    if not lags or 0 not in lags:
        return 0
    kb = min(lags, key=lambda k: lags[k])
    s0, sb = lags[0], lags[kb]
    return kb if kb != 0 and s0 > sb * (1.0 + max(LAG_MIN_GAIN, 5.0 / math.sqrt(m))) and s0 - sb > LAG_MIN_DEG \
        else 0


def _transitions_named(kt: int, gain: float, t: float) -> bool:
    return kt != 0 and t > LAG_T and gain > LAG_T_GAIN


def _jumps_named(kj: int, fixed: int, made: int) -> bool:
    return kj != 0 and fixed >= LAG_JUMP_MIN_ROWS and made * LAG_JUMP_RATIO <= fixed


def _curve_rule(lag: float, se: float, halves: list) -> tuple:
    """(rule, k): the lag curve's nearest whole row k and how it is named:
    "curve" when each half of the log lies beyond half a row on its side
    and the whole curve LAG_CURVE_SE standard errors beyond it (nothing but a
    shift puts it there); "nearest" (a warning) when each half lies on its
    side and the curve's standard error is below LAG_CURVE_NEAREST_SE (a
    skew of the log's own of nearly half a row reads so too); "possible"
    when the halves lie on its side but the curve scatters more; None
    otherwise."""
    k = int(round(lag))
    # each half on its own on the side of the whole curve's nearest row (the whole curve gives the row: a
    # log with a skew of its own within a row, shifted by one, puts its halves either side of a row)
    if k == 0 or not all(h is not None and np.sign(h) == np.sign(k) for h in halves):
        return None, k
    if all(abs(h) > 0.5 for h in halves) and abs(lag) - 0.5 > LAG_CURVE_SE * se:
        return "curve", k
    return ("nearest" if se < LAG_CURVE_NEAREST_SE else "possible"), k


def _short_curve_names(lag: float, se: float, halves: list) -> bool:
    """Whether a lag curve of fewer than LAG_CURVE_ROWS rows (_lag_curve
    with min_rows=LAG_CURVE_SHORT_ROWS and refit: its fraction, standard
    error and halves, as _curve_rule takes them) names its row k: by the
    strict rule (_curve_rule's "curve"), each half of the log rounding to k,
    the standard error below LAG_CURVE_NEAREST_SE and the fraction within
    LAG_CURVE_SHORT_LEFT of k.  On such logs the first jackknife's standard
    error is too small: stretches of 1 000-1 600 rows of emulated hand
    tumbles in step (50-100 rows/s) read +0.39 +- 0.09 and -2.38 +- 0.69,
    and the nearest-row warning named a row on 4 of 106 stretches in step;
    the strict rule with the halves' rows alone still named +3 on a stretch
    of the CK log in step (+3.37 +- 0.8) and -2 on a tumble a row out of
    step (-1.53 +- 0.15); this rule with the first jackknife alone named +3
    on CK rows 6000-7500 in step (+3.33 +- 0.41; refitted, +- 1.38)."""
    rule, k = _curve_rule(lag, se, halves)
    return rule == "curve" and se < LAG_CURVE_NEAREST_SE and abs(lag - k) < LAG_CURVE_SHORT_LEFT \
        and all(int(round(h)) == k for h in halves)


def _short_rule_text() -> str:
    """_short_curve_names in words."""
    return (f"on fewer than {_rows_text(LAG_CURVE_ROWS)} rows the curve names a shift only where each half of the "
            f"log rounds to the same row, its scatter is under {LAG_CURVE_NEAREST_SE:g} row and it lies within "
            f"{LAG_CURVE_SHORT_LEFT:g} of the row")


def _rows_text(n: int) -> str:
    """A count of rows as the other figures are written (1 000)."""
    return f"{n:,}".replace(",", " ")


def _possible_shift(inv, k: int, why: str) -> Finding:
    """The note for a lag curve (_lag_curve's dict) that puts a shift k on
    the side of both halves of the log but does not name it (why: the
    rule it misses), with the rows one standard error either way allows."""
    lo, hi = (int(round(inv["lag"] + d * inv["se"])) for d in (-1, 1))
    shift = f"of {k:+d}" if lo == hi else f"anywhere from {lo:+d} to {hi:+d} rows (one standard error either way)"
    halves = ", ".join("too short to tell" if h is None else f"{h:+.2f}" for h in inv["halves"])
    return Finding("row-alignment", "note", (
        f"the dip invariant's lag curve puts the magnetometer's rows {inv['lag']:+.2f} +- {_se_text(inv['se'])} out "
        f"of step (each half of the log: {halves}): a shift {shift} is possible, not named ({why})"),
        None, {"curve_lag_rows": inv["lag"], "curve_lag_se_rows": inv["se"], "curve_lag_halves_rows": inv["halves"],
               "lag_rows_possible": k})


def _named_on(a, b, inv_shifted, strict=False) -> bool:
    """Whether the checks would name a shift of the rows a, b paired as given
    (the spread, the transitions, the jumps, or the lag curve inv_shifted:
    (lag, se, halves) of these rows; strict: a curve of fewer than
    LAG_CURVE_ROWS rows, _short_curve_names), leaving out the routes'
    second views."""
    if _spread_lag(_spread_by_lag(a, b), len(a)) or _transitions_named(*_lag_transitions(a, b)) \
            or _jumps_named(*_lag_jumps(a, b)):
        return True
    if inv_shifted is None:
        return False
    return _short_curve_names(*inv_shifted) if strict else _curve_rule(*inv_shifted)[0] in ("curve", "nearest")


def _shifts_unseen(ug, ub, inv, lags, strict=False, held=None):
    """A note, (message, figures), when a shift of one row either way would
    not be named on this log as it is (its rows shifted and checked as the
    checks check them, the lag curve moved by the row), or None: a log
    whose rows do not show their pairing (a hand-held log turned mostly
    about one axis, a short one, a fast one: a row is a few ms) is said to
    be unchecked rather than passed in silence.  (The caller leaves out
    one orientation: a shift changes nothing there.)"""
    if len(ug) < 4 * MAX_LAG + 40 or not lags or not lags.get(0):
        return None
    ways = []
    for k in (1, -1):
        a, b = (ug[:-1], ub[1:]) if k == 1 else (ug[1:], ub[:-1])
        # the curve of these rows moves by the row the other way (the accelerometer's row i with the
        # magnetometer's row i + k is a lag of -k)
        shifted = None if inv is None else (inv["lag"] - k, inv["se"],
                                            [None if h is None else h - k for h in inv["halves"]])
        if not _named_on(a, b, shifted, strict):
            ways.append(k)
    if not ways:
        return None
    gain = max(abs(lags.get(k, lags[0]) / lags[0] - 1.0) for k in (1, -1))
    why = (f"fewer than {_rows_text(LAG_CURVE_SHORT_ROWS)} consecutive rows" if len(ug) < LAG_CURVE_SHORT_ROWS else
           "the dip within 6 deg of the magnetic equator, too small to scale the invariant"
           if abs(float(np.median((ug * ub).sum(1)))) < LAG_CURVE_MIN_SIN else
           "both triads turned too little, or about one axis only")
    curve = (f"the dip invariant's lag curve, which finds a shift on a log turned smoothly, is not determined "
             f"here ({why})" if inv is None else
             f"the dip invariant's lag curve scatters by {_se_text(inv['se'])} row here" + (
                 f" ({_short_rule_text()})" if strict else ""))
    # k = 1 pairs the accelerometer's row i with the magnetometer's row i + 1: the magnetometer a row ahead
    # (named as lag -1), k = -1 a row behind (lag +1)
    which = "either way" if len(ways) == 2 else ("with the magnetometer a row ahead" if ways[0] == 1 else
                                                 "with the magnetometer a row behind")
    head = ("the triads' pairing is not checked to a row on these rows: a shift of one row either way would not be "
            "named" if len(ways) == 2 else
            f"the triads' pairing is not checked to a row {which} on these rows: such a shift would not be named, "
            f"one the other way would")
    if held is None:
        fix = "a session held still at each position, or a longer log turned through all orientations, checks it"
    else:
        # a step-and-hold log already: its changes of position are what show a shift, and moved slowly over many
        # rows a row's shift mispairs little of each (a phone-like controller's 197 holds, moved over 18 rows
        # each, had been told to hold still at each position)
        fix = (f"the log is held still already ({held[0]} holds found, moved between them over "
               f"{held[1] / max(held[0], 1):.0f} rows each on average): moves between the holds in a few rows each "
               f"(a quick turn, then still), or a longer log turned through all orientations, check it")
    return (f"{head} (a row changes the dip's spread by {100 * gain:.2g} %; {curve}); {fix}"), \
        {"unseen_lags_rows": [-k for k in ways], "spread_change_per_row": gain}


def _lag_jumps(ug, ub, K: int = MAX_LAG):
    """(best shift, rows it pairs again, rows it mispairs) for a log read at
    a few positions: for each shift, the rows whose dip deviation (from the
    running median of LAG_JUMP_WINDOW rows, as paired at that shift: the
    dip of the position they are read at, whatever error the triads'
    uncalibrated directions leave in it) is smaller by more than LAG_JUMP_K
    times the row-to-row noise (and LAG_JUMP_DEG) than as logged, and the
    rows where it is larger by that much.  A shift of the rows at which the
    position changes leaves each of those rows far off; the right shift
    brings each one back and puts no other row out (a wrong shift puts
    twice as many out).  The best shift has most rows brought back less
    rows put out (a tie goes to the shift nearest the rows as logged: turns
    between the positions over several rows are paired again as well by a
    row more, and a half of six stops turned over ten rows read -2 for -1);
    (0, 0, 0) when no shift brings any back.  Shifts -K..K (MAX_LAG)."""
    m = len(ug)
    w = LAG_JUMP_WINDOW
    if m < 2 * K + 2 * w:
        return 0, 0, 0
    i = np.arange(K, m - K)
    dev, noise = {}, []
    for k in range(-K, K + 1):
        d = _dip(ug[i], ub[i + k])
        med = np.median(np.lib.stride_tricks.sliding_window_view(np.pad(d, w // 2, mode="edge"), w), axis=1)
        dev[k] = np.abs(d - med)
        noise.append(_robust_std(np.diff(d)) / math.sqrt(2.0))
    big = max(LAG_JUMP_K * min(noise), LAG_JUMP_DEG)
    best = (0, 0, 0)
    for k in sorted(range(-K, K + 1), key=abs)[1:]:
        fixed = int(np.sum(dev[0] - dev[k] > big))
        made = int(np.sum(dev[k] - dev[0] > big))
        if fixed - made > best[1] - best[2]:
            best = (k, fixed, made)
    return best


def _wide_lag(ug, ub):
    """A shift of more than MAX_LAG rows (two files started apart, not a
    lost line): (route, k, how, figures) or None.  The routes that find a
    shift within MAX_LAG (the dip's spread, a step-and-hold log's
    transitions, a few positions' jumps) each search up to LAG_WIDE rows
    either way (leaving LAG_WIDE_PAIRED rows paired).  A route's shift
    beyond MAX_LAG counts when its own rule names it, each half of the log
    puts the route's best shift within MAX_LAG - 1 rows of it (a half too
    short to tell is no objection; where neither half can, the dip spreads
    LAG_RATIO times less there than at every shift but its neighbours),
    and, for the transitions and jumps, the dip spreads there within its
    precision of its least (a moving log's spread is least near its
    pairing; a periodic turn can make the others' deviations least a
    period away).  Within MAX_LAG rows the narrower routes and the lag
    curve decide.

    The row: the lag curve of the rows paired at the shift found moves it
    by the whole row its own rule names (_curve_rule), or puts them in
    step (_in_step); without a curve, a transitions or jumps
    shift is the row where a row either way mispairs the changes of
    position (_row_sharp), and the spread's where its neighbours spread
    more by its precision.  A route whose row is not fixed gives way to a
    later one that fixes a row within MAX_LAG - 1 of it;
    figures["wide_row_fixed"] says which."""
    m = len(ug)
    gain = 1.0 + max(LAG_MIN_GAIN, 5.0 / math.sqrt(m))

    def width(n):
        return min(LAG_WIDE, n - LAG_WIDE_PAIRED)

    def spread(a, b):
        w = width(len(a))
        if w <= MAX_LAG:
            return None
        sp = _spread_by_lag(a, b, w)
        k = min(sp, key=sp.get)
        return k, (k if _spread_lag(sp, len(a) - abs(k)) else 0)

    def transitions(a, b):
        w = width(len(a))
        if w <= MAX_LAG or len(a) < 4 * w + 40:
            return None
        r = _lag_transitions(a, b, w)
        return r[0], (r[0] if _transitions_named(*r) else 0), r

    def jumps(a, b):
        w = width(len(a))
        if w <= MAX_LAG or len(a) > LAG_WIDE_JUMP_ROWS or len(a) < 2 * w + 2 * LAG_JUMP_WINDOW:
            return None
        r = _lag_jumps(a, b, w)
        k = r[0] if _jumps_named(*r) else 0
        return (k or None), k, r  # a half's best shift: only one its rule names

    h = m // 2
    sp = _spread_by_lag(ug, ub, width(m)) if width(m) > MAX_LAG else {}
    found = None
    # the transitions and the jumps count only where the dip spreads within its precision of its least: where
    # no shift beyond MAX_LAG does (a moving log's spread rises either side of its pairing), they are not run
    others = sp and any(abs(k) > MAX_LAG and v <= min(sp.values()) * gain for k, v in sp.items())
    for name, find in (("spread", spread), ("transitions", transitions), ("jumps", jumps)):
        if name != "spread" and not others:
            break
        r = find(ug, ub)
        k = 0 if r is None else r[1]
        if abs(k) <= MAX_LAG:
            continue
        if name != "spread" and sp[k] > min(sp.values()) * gain:
            continue
        halves = []
        for sl in (slice(0, h), slice(h, m)):
            # a half whose search does not reach the shift cannot tell (24-60 positions shifted by 20)
            rh = find(ug[sl], ub[sl]) if width(len(ug[sl])) >= abs(k) else None
            halves.append(None if rh is None else rh[0])
        if any(x is not None and abs(x - k) >= MAX_LAG for x in halves):
            continue
        if all(x is None for x in halves) and not _stands_out(sp, k):
            # no half can tell (a short log, or a shift beyond a half's search): 28 positions shifted by 20,
            # searched to 16, read 17.3 deg at -15 against 42.7 as paired; 30 shifted by 20: 13.9 at -13
            continue
        wd = width(m)
        fig = {"wide_lag_rows": k, "wide_route": name, "wide_halves_lag_rows": halves, "wide_rows_searched": wd}
        if name == "spread":
            how = (f"the dip angle spreads {sp[0]:.3g} deg as paired, {sp[k]:.3g} deg with the "
                   f"magnetometer's rows shifted by {k:+d}, the least of the shifts up to {wd} rows either way")
        elif name == "transitions":
            how = (f"the dip angle's mean deviation is {r[2][1]:.3g} times larger as paired than with the "
                   f"magnetometer's rows shifted by {k:+d}, the least of the shifts up to {wd} rows either way "
                   f"(the rows where the position changes are mispaired)")
        else:
            how = (f"{r[2][1]} rows where the position changes read a dip far off as paired and in line with the "
                   f"magnetometer's rows shifted by {k:+d} ({r[2][2]} the other way), of the shifts up to {wd} rows "
                   f"either way")
        how += " (each half of the log on its own: " + ", ".join(
            "too short to tell" if x is None else f"{x:+d}" for x in halves) + ")"
        inv = _lag_curve(*_paired(ug, ub, k))
        if inv is not None:
            rule, rk = _curve_rule(inv["lag"], inv["se"], inv["halves"])
            fig.update({"curve_lag_rows": k + inv["lag"], "curve_lag_se_rows": inv["se"],
                        "curve_lag_halves_rows": [None if x is None else k + x for x in inv["halves"]]})
            if rule in ("curve", "nearest") and abs(rk) < MAX_LAG:
                how += (f"; with the rows paired so, the dip invariant's lag curve puts them a further "
                        f"{inv['lag']:+.2f} +- {_se_text(inv['se'])} rows out of step: {k + rk:+d} in all")
                k += rk
                pinned = True
            else:
                pinned = _in_step(inv)
                how += (f"; with the rows paired so, the dip invariant's lag curve puts them "
                        f"{inv['lag']:+.2f} +- {_se_text(inv['se'])} rows from there")
        elif name == "spread":
            pinned = abs(k) < width(m) and min(sp[k - 1], sp[k + 1]) > sp[k] * gain
        else:
            pinned = _row_sharp(*_paired(ug, ub, k))
        fig.update({"wide_row_fixed": pinned, "dip_spread_at_lag_deg": _robust_std(_dip(*_paired(ug, ub, k)))})
        if pinned and (found is None or abs(k - found[1]) < MAX_LAG):
            return name, k, how, fig
        if found is None:
            found = (name, k, how, fig)
    return found


def _curve_in_step(ug, ub) -> bool:
    """Whether the dip invariant's lag curve puts these rows in step: its
    fraction and each half's within half a row of 0, its standard error
    below LAG_CURVE_NEAREST_SE (the CK log four rows ahead, its curve at
    -4.39 +- 0.16 from the trials at the edge of the rows tried: paired at
    -4, -0.07 +- 0.11, halves +0.03 and -0.13)."""
    return _in_step(_lag_curve(ug, ub))


def _in_step(inv) -> bool:
    """Whether a lag curve (_lag_curve's dict, or None) puts its rows in
    step: see _curve_in_step."""
    return inv is not None and abs(inv["lag"]) < 0.5 and inv["se"] < LAG_CURVE_NEAREST_SE \
        and all(h is not None and abs(h) < 0.5 for h in inv["halves"])


def _row_sharp(ug, ub) -> bool:
    """Whether the rows as paired are paired to the row by the rows where
    the position changes: a row either way raises the dip's mean absolute
    deviation LAG_T_GAIN times, at LAG_T standard errors of the blocks
    (_lag_transitions' statistics).  On a step-and-hold log a row's error
    mispairs each change of position (SAP6's shots held 30 rows: 1.6-5x,
    t 4.2-4.9); on a moving log a row changes the deviation by 1-3 % (CK),
    and the row there is as skewed as the spread's."""
    if len(ug) < 44:
        return False
    dev = _deviations(ug, ub, 1)
    return all(np.mean(dev[k]) > LAG_T_GAIN * np.mean(dev[0]) and _block_t(dev[k] - dev[0])[1] > LAG_T
               for k in (-1, 1))


def _paired(ug, ub, k: int):
    """The accelerometer's row i with the magnetometer's row i + k."""
    m = len(ug)
    return (ug[:m - k], ub[k:]) if k >= 0 else (ug[-k:], ub[:m + k])


def _savgol_rows(v, n, order=3):
    """Each column of v smoothed by a least-squares polynomial of this order
    over n (odd) consecutive rows, the first and last n // 2 rows from the
    first and last window's polynomial: scipy.signal.savgol_filter(v, n,
    order, axis=0) in its default mode ('interp'), without the 0.6 s import
    of scipy.signal on every `inclino import`."""
    h = n // 2
    V = np.vander(np.arange(-h, h + 1, dtype=float), order + 1, increasing=True)
    H = V @ np.linalg.pinv(V)  # row t: the fitted polynomial at window position t from the n values
    out = np.empty_like(v, dtype=float)
    win = np.lib.stride_tricks.sliding_window_view(v, n, axis=0)  # (rows - n + 1, cols, n)
    out[h:len(v) - h] = win @ H[h]
    out[:h] = H[:h] @ v[:n]
    out[len(v) - h:] = H[h + 1:] @ v[len(v) - n:]
    return out


def _se_text(se: float) -> str:
    """A lag's standard error as printed: two decimals, or two significant
    digits below 0.01 row (a clean smooth tumble's is a few thousandths: "0.00"
    read as no error at all)."""
    return f"{se:.2f}" if se >= 0.01 else f"{se:.2g}"


def _lever_arm_columns(ug, ub, i, shifts):
    """The hand's linear acceleration as the dip invariant sees it on a
    moving log (consecutive rows): for each trial shift k in shifts, 6
    columns for _invariant_misfit on the rows ug[i] paired with ub[i + k].

    A sensor held rigidly by a hand that turns it about a grip point r (in
    the sensor's frame) reads, beside gravity, a_lin = alpha x r +
    w x (w x r): w the rotation rate, alpha its derivative.  To first order
    a_lin tilts the accelerometer's direction by its part normal to g and
    moves the invariant g.b by a_lin . p, p = b - (g.b) g; that is linear in
    r:  (alpha x r) . p = r . (-alpha x p) (tangential) and
    (w x (w x r)) . p = r . (w x (w x p)) (centripetal).  The columns are
    -alpha x p and w x (w x p); the fit takes one r for each term (their
    coefficients): r is fitted, not assumed, and a log without a hand's
    acceleration fits it to ~0.  The tangential term is the rate's
    derivative, so left in the misfit it looks like a time shift between
    the triads: that is why the lag curve fits it out at each trial shift.

    w per row, from the rows as paired at that shift: both triads'
    directions are fixed in the world, so in the sensor's frame each turns
    as v' = v x w; least squares of that over both directions' central
    differences, each direction smoothed over LAG_LEVER_ROWS rows first
    (Savitzky-Golay, cubic), the accelerometer's weighted
    LAG_LEVER_ACC_WEIGHT (it is the direction a_lin moves); alpha by central
    differences of w.  Each triad's part of the normal equations is formed
    once; a shift only adds them and solves a 3x3 system per row.  Units:
    rad and rows, absorbed by the fitted coefficients."""
    def central(v):
        d = np.empty_like(v)
        d[1:-1] = 0.5 * (v[2:] - v[:-2])
        d[0], d[-1] = d[1], d[-2]
        return d

    def normal_part(v, weight2):  # weight2 * (I - v v^T) w = -weight2 * v x v'  (from v' = v x w)
        s = _savgol_rows(v, LAG_LEVER_ROWS)
        s /= np.maximum(np.linalg.norm(s, axis=1, keepdims=True), 1e-300)
        return weight2 * (np.eye(3) - s[:, :, None] * s[:, None, :]), -weight2 * np.cross(s, central(s))

    m = len(ug)
    Ag, rg = normal_part(ug, LAG_LEVER_ACC_WEIGHT ** 2)
    Ab, rb = normal_part(ub, 1.0)
    Ag += 1e-9 * np.eye(3)  # a row with g along b does not see the turn about them: 0 there, not singular
    out = []
    for k in shifts:
        j0, j1 = max(0, -k), min(m, m - k)  # every row the shift pairs: the fitted rows' neighbours too
        w = np.linalg.solve(Ag[j0:j1] + Ab[j0 + k:j1 + k], (rg[j0:j1] + rb[j0 + k:j1 + k])[:, :, None])[:, :, 0]
        alpha, w = central(w)[i - j0], w[i - j0]
        g, b = ug[i], ub[i + k]
        p = b - (g * b).sum(1, keepdims=True) * g
        out.append(np.column_stack([-np.cross(alpha, p), np.cross(w, np.cross(w, p))]))
    return out


def _invariant_design(ug, ub, extra=None):
    """The columns of the dip invariant's fit, g^T C b + u.g + v.b = 1 (15
    coefficients: a constant dip through any small misalignment, scale,
    cross-axis and offset error of either triad), plus any extra columns
    (the hand's lever-arm terms, _lever_arm_columns), each scaled to unit
    RMS (the lever-arm columns are ~1e-3 of the others; scaled, the normal
    equations are well conditioned)."""
    cols = [(ug[:, :, None] * ub[:, None, :]).reshape(len(ug), 9), ug, ub]
    X = np.column_stack(cols if extra is None else cols + [extra])
    scale = np.sqrt((X * X).mean(0))
    return X / np.where(scale > 0, scale, 1.0)


def _invariant_misfit(ug, ub, extra=None):
    """The dip invariant's misfit per row (_invariant_design) with its
    coefficients fitted by least squares, through the normal equations:
    the same residual as a least-squares solver on the rows, at a fraction
    of its cost (the curve fits it 27 times)."""
    X = _invariant_design(ug, ub, extra)
    y = np.ones(len(ug))
    return y - X @ np.linalg.lstsq(X.T @ X, X.T @ y, rcond=None)[0]


def _invariant_misfit_blocks(ug, ub, extra, block, nb, refit=False):
    """The dip invariant's squared misfit (_invariant_misfit) summed over
    each block 0..nb-1 of rows (block: each row's; nb: a row left out), and
    (refit) for each block the sum over the other blocks' rows with the
    coefficients fitted without the block's rows (the normal equations less
    the block's part; zeros without refit)."""
    X = _invariant_design(ug, ub, extra)
    y = np.ones(len(ug))
    A, r = X.T @ X, X.T @ y
    res2 = (y - X @ np.linalg.lstsq(A, r, rcond=None)[0]) ** 2
    sums = np.bincount(block, weights=res2, minlength=nb + 1)[:nb]
    loo = np.zeros(nb)
    if refit:
        used = block < nb
        for j in range(nb):
            sel = block == j
            if not sel.any():
                loo[j] = sums.sum()
                continue
            Xb = X[sel]
            cj = np.linalg.lstsq(A - Xb.T @ Xb, r - Xb.T @ y[sel], rcond=None)[0]
            keep = used & ~sel
            loo[j] = np.sum((y[keep] - X[keep] @ cj) ** 2)
    return sums, loo


def _turn_blocks(ug, ub, nb) -> float:
    """How many of nb blocks of consecutive rows the triads' turning is
    spread over: (sum T)^2 / sum T^2, T each block's sum of both unit
    directions' central differences (nb where every block turns alike;
    a log held still at each of six positions, about 5)."""
    turn = np.linalg.norm(ug[2:] - ug[:-2], axis=1) + np.linalg.norm(ub[2:] - ub[:-2], axis=1)
    L = max(len(turn) // nb, 1)
    T = np.bincount(np.minimum(np.arange(len(turn)) // L, nb - 1), weights=turn, minlength=nb)
    return float(T.sum() ** 2 / max(float((T ** 2).sum()), 1e-300))


def _curve_vertex(V, K):
    """Fractional minimum of V[-K-1 .. K+1] (a parabola through the best
    trial within -K..K and its neighbours); None if not convex there."""
    kb = min(range(-K, K + 1), key=lambda k: V[k + K + 1])
    a, b, c = V[kb + K], V[kb + K + 1], V[kb + K + 2]
    den = a - 2.0 * b + c
    return kb + 0.5 * (a - c) / den if den > 0 else None


def _lag_curve(ug, ub, halves=True, lever_arm=True, min_rows=LAG_CURVE_ROWS, refit=False):
    """The fractional row shift of the magnetometer against the
    accelerometer that makes the dip invariant most consistent, for a
    continuously moving log: for each trial shift -K-1..K+1 the mean squared
    misfit of the invariant after fitting out the triads' calibration and
    (lever_arm) the hand's linear acceleration, its lever-arm terms taken
    from the rows as paired at that shift (_invariant_misfit,
    _lever_arm_columns), the vertex of that curve, its standard error by a
    jackknife over LAG_CURVE_BLOCKS blocks of consecutive rows, and the same
    vertex from each half of the log fitted on its own.  The whole log's
    curve fits the calibration and the lever arms to each of its
    LAG_CURVE_PARTS parts on its own and sums their misfits: a hand changes
    its grip, a part warms, and one fit for the whole log leaves what
    changed in the misfit (on CK's log, which then leans +0.18 row where
    each half fitted alone is at +0.02 and -0.13).  With refit, the standard
    error is the larger of that jackknife and one that fits the calibration
    and the lever arms again without each block (the first leaves each
    block's weight in the fitted terms: on a short log a few blocks can
    carry them, and its standard error is then too small).  None when the
    log is too short or the dip too close to 0 to scale the invariant."""
    m = len(ug)
    K = MAX_LAG
    if m < (min_rows if halves else min_rows // 2):
        return None
    if abs(float(np.median((ug * ub).sum(1)))) < LAG_CURVE_MIN_SIN:
        return None
    if max(np.linalg.norm(ug.mean(0)), np.linalg.norm(ub.mean(0))) > LAG_CURVE_MAX_RESULTANT:
        # a log that hardly turns (one orientation held, or turned about gravity alone) pairs its rows alike
        # at every shift: the curve would be its noise (fitted to it by the lever-arm terms)
        return None
    nb = LAG_CURVE_BLOCKS
    if halves and _turn_blocks(ug, ub, nb) < LAG_CURVE_MIN_TURN_BLOCKS:
        # the turns in a few blocks (a step-and-hold log of a few positions): the curve rests on a few dozen
        # rows and the jackknife, its blocks not alike, cannot tell how well (six positions held 100 rows,
        # turned between over 3 rows, a row ahead: +2.50 +- 0.002)
        return None
    i = np.arange(K + 1, m - K - 1)
    shifts = range(-K - 1, K + 2)
    extra = _lever_arm_columns(ug, ub, i, shifts) if lever_arm else [None] * len(shifts)
    parts = np.array_split(np.arange(len(i)), LAG_CURVE_PARTS if halves else 1)
    L = len(i) // nb
    block = np.minimum(np.arange(len(i)) // L, nb)  # nb: the rows past the last whole block, left out
    S = np.zeros((len(shifts), nb))     # each block's squared misfit, the coefficients fitted to every row
    loo = np.zeros((len(shifts), nb))   # the other blocks', the coefficients fitted without the block
    for si, (k, x) in enumerate(zip(shifts, extra)):
        for p in parts:
            s_b, loo_b = _invariant_misfit_blocks(ug[i[p]], ub[i[p] + k], None if x is None else x[p], block[p], nb,
                                                  refit)
            S[si] += s_b
            loo[si] += loo_b
    tot = S.sum(1)
    lag = _curve_vertex(tot, K)
    if lag is None:
        return None
    tj = [_curve_vertex(tot - S[:, j], K) for j in range(nb)]
    if refit:
        tj += [_curve_vertex(loo[:, j], K) for j in range(nb)]
    if any(t is None for t in tj):
        return None
    tj = np.array(tj).reshape(-1, nb)
    se = float(max(np.sqrt((nb - 1) / nb * np.sum((t - t.mean()) ** 2)) for t in tj))
    out = {"lag": float(lag), "se": se, "halves": []}
    if halves:
        h = m // 2
        for sl in (slice(0, h), slice(h, m)):
            r = _lag_curve(ug[sl], ub[sl], halves=False, lever_arm=lever_arm, min_rows=min_rows)
            out["halves"].append(None if r is None else r["lag"])
    return out


def _acc_poses(ds, rows, rep):
    """The accelerometer's directions against the poses' gravity:
    orthogonal Procrustes with and without a reflection; the lag that fits
    best."""
    from inclino.engines import reference as ref

    inc = ds.columns["inc_deg"]
    tf = ds.columns["tf_deg"]
    azi = ds.columns.get("azi_deg", np.zeros(len(ds)))
    n = len(ds)
    block = np.arange(min(n, LAG_ROWS))
    C = ref.pose_matrix(inc[block], azi[block], tf[block])
    gp = C[:, :, 2]  # gravity (down) in body axes
    a = ds.acc[block]
    ua = a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)

    def procrustes(x, y):
        U, _, Vt = np.linalg.svd(x.T @ y)
        R = U @ Vt
        Rr = U @ np.diag([1.0, 1.0, -1.0]) @ Vt
        if np.linalg.det(R) < 0:
            R, Rr = Rr, R
        return R, e(x, y, R), Rr, e(x, y, Rr)

    def e(x, y, M):
        """The directions' RMS miss under M over the best POSE_FIT_KEEP of
        the rows: the rows read while the sensor is moved from one pose to
        the next miss their labelled pose by tens of degrees (a six-face
        session, 5.5 % of its rows beyond 30 deg: over every row a mirrored
        axis read 0.397 against 1.082 for the best rotation, not the 0.3 an
        error needs; over the best 90 %, 0.075 against 0.927)."""
        d = np.sort(np.sum((x - y @ M.T) ** 2, 1))
        return float(np.sqrt(np.mean(d[:max(1, int(np.ceil(POSE_FIT_KEEP * len(d))))])))

    if len(np.unique(np.round(gp, 2), axis=0)) < 3:
        return gp
    rs = np.asarray(rows)
    a_r = ds.acc[rs]
    same = _poses_one_direction(a_r / np.maximum(np.linalg.norm(a_r, axis=1, keepdims=True), 1e-300),
                                ref.pose_matrix(inc[rs], azi[rs], tf[rs])[:, :, 2], inc[rs], tf[rs], rs)
    if same is not None:
        # no axis map (rotation or mirror) turns two directions into one: the Procrustes fits below would name a
        # mirror or a turned map for what is a label on the wrong rows
        rep.findings.append(Finding("poses", "error", same[0], "acc", same[1]))
        return gp
    R, e_rot, Rr, e_ref = procrustes(ua, gp)
    fig = {"rms_rotation": e_rot, "rms_reflection": e_ref}
    if e_ref < 0.3 * e_rot and e_rot > 0.1 and not intended_reflection(ds, "acc"):
        if np.allclose(Rr, -np.eye(3), atol=0.2):
            msg = (f"the accelerometer reads gravity with the wrong sign against the poses (its directions are the "
                   f"poses' reversed: RMS {e_ref:.3g} reversed, {e_rot:.3g} as a rotation, over the best "
                   f"{POSE_FIT_KEEP:.0%} of the rows): an axis pointing down must read +1 g; "
                   + _fix(ds, "accelerometer", "reads (\"up\" for most MEMS parts)"))
            rep.findings.append(Finding("dip-sign", "error", msg, "acc", fig))
        else:
            rep.findings.append(Finding("handedness", "error", (
                f"the accelerometer's axes are mirrored against the poses (direction RMS {e_ref:.3g} with a "
                f"reflection, {e_rot:.3g} with the best rotation, over the best {POSE_FIT_KEEP:.0%} of the rows): "
                f"a left-handed axis map, or poses that mirror a right one (the poses of two opposite faces "
                f"swapped: +x labelled as -x); "
                + ("the declared reflection ([accelerometer] reflection = true) does not fit the data as mapped: "
                   + _fix(ds, "accelerometer", "the axis map (one sign, without reflection = true)")
                   if declared_reflection(ds, "acc") else
                   _fix(ds, "accelerometer", "the axis map (or reflection = true if intended)"))), "acc", fig))
    else:
        _acc_rotation(ds, ua, gp, R, rep, fig)
    # the accelerometer rows against the poses' rows, shifted
    m = len(block)
    errs = {}
    for k in range(-MAX_LAG, MAX_LAG + 1):
        if m - abs(k) < 6:
            continue
        x, y = (ua[k:], gp[:m - k]) if k >= 0 else (ua[:m + k], gp[-k:])
        Rk = procrustes(x, y)[0]
        errs[k] = float(np.degrees(np.sqrt(np.median(np.sum((x - y @ Rk.T) ** 2, 1)))))
    if not errs:
        return gp
    kb = min(errs, key=lambda k: errs[k])
    if kb != 0 and errs[0] > 1.5 * errs[kb] and errs[0] > MIN_SPREAD_DEG:
        level = "error" if errs[0] > LAG_RATIO * errs[kb] and errs[0] > 2.0 else "warning"
        rep.findings.append(Finding("row-alignment", level, (
            f"the accelerometer's rows and the poses are out of step: the gravity direction misses the poses by "
            f"{errs[0]:.3g} deg (median) as paired, {errs[kb]:.3g} deg with the readings shifted by {kb:+d} rows; "
            f"the pose columns and the readings were joined one row off"), "acc",
            {"misfit_by_lag_deg": {str(k): v for k, v in errs.items()},
             "fix": f"join the pose columns to the readings shifted by {kb:+d} rows"}))
    return gp


def _poses_one_direction(ua, gp, inc, tf, rows):
    """(message, figures) when the rows of two poses whose gravity lies
    POSE_APART_DEG or more apart read one direction (their median
    directions within POSE_SAME_DEG and a third of the poses' angle), else
    None.  An axis map turns every direction alike, so no map, mirrored or
    not, makes two poses read one: a label or a pose column is on the
    wrong rows.  (A six-face session whose "posZ" file held a second
    recording of the -z face: the accelerometer was called mirrored against
    the poses, RMS 0.06 with a reflection over the best 90 % of the rows,
    the rows of the other z face being the 10 % left out.)"""
    keys, inv, counts = np.unique(np.round(gp, 2), axis=0, return_inverse=True, return_counts=True)
    inv = np.asarray(inv).reshape(-1)
    groups = []
    for g in range(len(keys)):
        if counts[g] < POSE_GROUP_ROWS:
            continue
        idx = np.flatnonzero(inv == g)
        d = np.median(ua[idx], axis=0)
        nd = float(np.linalg.norm(d))
        if not nd > 0:
            continue
        p = np.mean(gp[idx], axis=0)
        groups.append((idx, d / nd, p / np.linalg.norm(p)))
    ang = lambda u, v: float(np.degrees(np.arccos(np.clip(np.dot(u, v), -1.0, 1.0))))  # noqa: E731
    worst = None
    for i in range(len(groups)):
        for j in range(i + 1, len(groups)):
            apart, seen = ang(groups[i][2], groups[j][2]), ang(groups[i][1], groups[j][1])
            if apart >= POSE_APART_DEG and seen <= min(POSE_SAME_DEG, apart / 3.0):
                if worst is None or apart - seen > worst[0]:
                    worst = (apart - seen, i, j, apart, seen)
    if worst is None:
        return None
    _, i, j, apart, seen = worst

    def pose(g):
        idx = groups[g][0]
        return (f"inc {float(inc[idx[0]]):.4g} tf {float(tf[idx[0]]):.4g} ({len(idx)} rows looked at, rows "
                f"{rows[idx[0]] + 1}...{rows[idx[-1]] + 1})")

    msg = (f"the rows of two poses read one gravity direction: {pose(i)} and {pose(j)}, whose gravity lies "
           f"{apart:.0f} deg apart, read within {seen:.2g} deg of each other; no axis map turns two directions into "
           f"one, so a pose label (or the pose columns) is on the wrong rows (one face recorded twice, a file "
           f"named for another face); check the [poses] labels against the log")
    return msg, {"pose_rows": [int(len(groups[i][0])), int(len(groups[j][0]))], "poses_apart_deg": apart,
                 "readings_apart_deg": seen}


def _acc_rotation(ds, ua, gp, R, rep, fig) -> None:
    """The accelerometer's directions against the poses' gravity turned by
    the best rotation R (not mirrored): R far from the identity and fitting
    where the identity does not is an axis map turned (a warning: the fit
    absorbs a rotation, started from that map; an MPU-6050's six faces
    mapped "y, -x, z" imported without a word, and calibrate fitted acc_m a
    90 deg rotation); no rotation fitting either is poses that do not match
    the rows (an error: a six-position log's pose labels one row out of
    step fitted acc_m with determinant -0.24, refused as a mirror "against
    the magnetometer" of a log without one)."""
    ang = lambda M: np.degrees(np.arccos(np.clip(np.sum(ua * (gp @ M.T), 1), -1.0, 1.0)))  # noqa: E731
    miss_rot, miss_id = float(np.median(ang(R))), float(np.median(ang(np.eye(3))))
    fig = {**fig, "median_miss_rotation_deg": miss_rot, "median_miss_as_given_deg": miss_id}
    if miss_rot > POSE_MISFIT_DEG:
        rep.findings.append(Finding("poses", "error", (
            f"the accelerometer's gravity directions fit no turn of the poses': they miss them by {miss_rot:.3g} deg "
            f"(median) with the best rotation, {miss_id:.3g} deg as given: the poses do not match the rows (pose "
            f"labels or columns out of step with the readings, the wrong pose columns, or a sensor that moved on "
            f"its mount); check the [poses] columns and labels against the log"), "acc", fig))
        return
    turn = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))
    if turn > AXES_TURN_DEG and miss_id > AXES_RATIO * max(miss_rot, 0.1):
        # the axis map (imported body -> the poses' body) that fits best: the proper signed permutation P whose
        # turn P^T of the poses misses the readings least; named when it fits about as well as the best rotation
        P = min(signed_permutations(proper=True), key=lambda Q: float(np.median(ang(Q.T))))
        shown = _perm_text(P @ _declared_map(ds, "acc"), "a")
        exact = float(np.median(ang(P.T))) < 2.0 * max(miss_rot, 0.5)
        rep.findings.append(Finding("axes", "warning", (
            f"the accelerometer's axes are turned {turn:.0f} deg against the poses: gravity misses them by "
            f"{miss_id:.3g} deg (median) with the axes as given, {miss_rot:.3g} deg turned (a rotation; the fit "
            f"absorbs it, started from that map)"
            + (f"; " + _fix(ds, "accelerometer", f"the axis map: axes = \"{shown}\"") if exact else
               "; check the accelerometer's axis map and the poses' zero (inc, tf)")), "acc",
            {**fig, "turn_deg": turn}))


def _motion(ds, rep):
    """Static or moving, from the readings' own spread: consecutive readings
    (or the readings within one pose) against each triad's noise -- the
    declared noise, else the most a MEMS part of that kind has
    (NOISE_BOUND).  A time column says nothing about it."""
    n = len(ds)
    block = np.arange(min(n, LAG_ROWS))
    if len(block) < 8:
        return
    verdicts, held = [], []
    for t in ("acc", "mag"):
        if not getattr(ds, f"has_{t}"):
            continue
        unit = "g" if t == "acc" else "nT"
        v = getattr(ds, t)[block]
        d1 = np.abs(np.diff(v, axis=0))
        # per-axis step: a static reading's consecutive difference is sqrt(2) x its noise
        step = float(np.median(d1) / 0.6745 / math.sqrt(2.0))
        declared = ds.meta.get(f"{t}_noise_{unit}")
        lsb = ds.meta.get(f"{t}_lsb_{unit}")
        bound = float(declared) if declared else NOISE_BOUND[t]
        bound = max(bound, float(lsb) if lsb else 0.0)
        rep.noise[f"{t}_step_{unit}"] = step
        same = float(np.mean(np.all(np.diff(v, axis=0) == 0, axis=1)))
        if same > HELD_FRAC:
            # a triad sampled slower than the rows and repeated between its updates: its median step is 0
            held.append(f"the {'accelerometer' if t == 'acc' else 'magnetometer'} repeats the row before on "
                        f"{100 * same:.0f} % of rows: read slower than the rows, held between its updates")
        if step <= 3.0 * bound:
            verdicts.append(True)
            rep.noise[f"{t}_{unit}"] = step
        else:
            verdicts.append(False)
        rep.noise[f"{t}_bound_{unit}"] = bound
    declared = declared_static(ds) or rep.declared_static
    rep.declared_static = declared
    turning = None
    if all(verdicts) and not declared:
        turning = _turning_slowly(ds, rep)
    if all(verdicts) and turning is None:
        rep.static = True
        if declared:
            _declared_static_moving(ds, rep)
        _holds_note(ds, rep)
        return
    if turning is not None:
        rep.static = False
        rep.findings.append(Finding("motion", "note", turning[0], None, turning[1]))
        return
    rep.static = False if not declared else None
    steps = _steps_text(rep)
    held = f" ({'; '.join(held)})" if held else ""
    if declared:
        rep.findings.append(Finding("motion", "note", (
            f"declared static; consecutive readings differ by a median of {steps} per axis (more than a static "
            f"sensor's noise){held}: each row is a position of its own, or the sensor moved"), None,
            {k: v for k, v in rep.noise.items() if "_step_" in k}))
    else:
        rep.findings.append(Finding("motion", "note", (
            f"consecutive readings differ by a median of {steps} per axis, more than a static sensor's noise{held}: "
            f"the sensor moved between rows (hand-held, continuous rotation), or each row is a position of its "
            f"own (declare a step-and-hold run static: --static, or [log] static = true)"), None,
            {k: v for k, v in rep.noise.items() if "_step_" in k}))


def _steps_text(rep) -> str:
    """The median step between consecutive readings per axis, each triad's
    in its unit ("accelerometer 2.3 mg, magnetometer 133 nT")."""
    return ", ".join(f"{'accelerometer' if k.startswith('acc') else 'magnetometer'} "
                     f"{v * (1e3 if k.startswith('acc') else 1):.3g} {'mg' if k.startswith('acc') else 'nT'}"
                     for k, v in rep.noise.items() if "_step_" in k and v > 0)


def _turning_slowly(ds, rep):
    """(text, figures) when consecutive readings differ by no more than a
    static sensor's noise but the readings hold still for HOLD_ROWS rows on
    fewer than STEP_AND_HOLD_FRACTION of the rows (inclino.holds.find: a
    steady turn is no hold): a sensor turned slowly and smoothly, its step
    a row within the noise bound (a QMC5883L turned by hand at 50 Hz, or a
    MEMS triad turned 0.1-1 deg a row, 1.2-6.5 mg a row against 3x the 5 mg
    bound, were read as static).  None for a log whose rows say which
    belong together (poses, a pose id), that reads one orientation, or is
    too short for a hold (fewer than MOTION_MIN_HOLDS x HOLD_ROWS rows)."""
    from inclino import holds

    if holds.labelled(ds) or rep.one_orientation or len(ds) < MOTION_MIN_HOLDS * holds.HOLD_ROWS:
        return None
    h = holds.find(ds)
    if h.step_and_hold:
        return None
    share = h.rows_held / len(ds)
    steps = _steps_text(rep)
    return ((f"consecutive readings differ by a median of {steps} per axis, within a static sensor's noise, but "
             f"only {100 * share:.0f} % of the rows hold still for {holds.HOLD_ROWS} rows ({h.count} holds found in "
             f"the readings): the sensor turned slowly between rows (hand-held, continuous rotation), not "
             f"step-and-hold (declare a run static only if every row was read at rest: --static, or [log] "
             f"static = true)"),
            {**{k: v for k, v in rep.noise.items() if "_step_" in k}, "rows_held_share": share, "holds": h.count})


def _declared_static_moving(ds, rep):
    """A step-and-hold log declared static whose rows between the holds
    carry a hand's acceleration: declared static, each stretch read for
    fewer than HOLD_ROWS rows counts as a station of its own (holds.find),
    and every such row is fitted as read at rest.  The accelerometer says
    otherwise: through the ellipsoid of the holds' own rows (HOLD_ROWS or
    more), rows at rest read |g| within the noise, and those rows misfit it
    by STATIC_MOVING_K times the holds' rows or more.  A rig's short
    stations read at rest fit it as the holds do; a sensor turned slowly
    enough to read no acceleration is as good as at rest and is not named.
    A warning (mikoff/imu-calib's MPU-9150 logs declared static: 2 459 rows
    between 118 holds, 17 mg against 4 mg; the calibration fitted 2 435
    "holds" and its predicted inclination sigma rose from 0.06 to 0.26 deg)."""
    from inclino import holds
    from inclino.calib.ellipsoid import determined, ellipsoid_start

    if not ds.has_acc or holds.labelled(ds) or rep.one_orientation or \
            ("inc_deg" in ds.columns and "tf_deg" in ds.columns):
        return  # (a log with the accelerometer's poses is fitted against them: declared static or not, the same)
    h = holds.find(ds)
    lab = h.labels
    if h.count < 2:
        return
    cnt = np.bincount(lab[lab >= 0], minlength=h.count)
    still = np.isin(lab, np.flatnonzero(cnt >= holds.HOLD_ROWS))
    short = ~still
    n = len(ds)
    if still.sum() < holds.STEP_AND_HOLD_FRACTION * n or short.sum() < max(STATIC_MOVING_MIN_ROWS,
                                                                           0.02 * n):
        return
    a = np.asarray(ds.acc, float)
    G = float(ds.meta.get("gravity_g") or 1.0)
    if not determined(a[still], G):
        return
    try:
        with np.errstate(all="ignore"):
            M, b = ellipsoid_start(a[still], G)
    except (DataError, np.linalg.LinAlgError, ValueError):
        return
    r = np.abs(np.linalg.norm((a - b) @ M.T, axis=1) - G)
    held, moved = float(np.median(r[still])), float(np.median(r[short]))
    if not (np.isfinite(held) and np.isfinite(moved)) or moved < STATIC_MOVING_K * max(held, 1e-9):
        return
    k = int(np.sum(cnt >= holds.HOLD_ROWS))
    rep.findings.append(Finding("motion", "warning", (
        f"declared static, but the {int(short.sum())} rows between its {k} holds were read while moving: through "
        f"the holds' own ellipsoid their |g| misfits by a median {1e3 * moved:.3g} mg against {1e3 * held:.3g} mg "
        f"in the holds ({moved / max(held, 1e-9):.2g}x: a hand's or a motor's acceleration, which no row read at "
        f"rest has), and declared static each is fitted as a station of its own; drop the declaration (--static, "
        f"[log] static, # static=true): the holds are found in the readings and the moving rows left out"), "acc",
        {"rows_moving": int(short.sum()), "holds": k, "moving_misfit_g": moved, "held_misfit_g": held}))


def _holds_note(ds, rep):
    """A still log that moved between its holds (a six-face session turned
    by hand): the holds and the rows read while moving, from the readings
    (inclino.holds); pose-free diagnose fits the holds, not the motion."""
    from inclino import holds

    if holds.labelled(ds) or rep.one_orientation:
        # (one orientation: its "holds" are one pose, and the rows between them jitter, not a turn; an LSM303
        # standing still on a robot was said to move between 7 holds)
        return

    h = holds.find(ds)
    if h.step_and_hold and h.rows_moving >= HOLDS_MOVING_NOTE * len(ds):
        rep.findings.append(Finding("motion", "note", (
            f"step-and-hold: {h.count} static holds found in the readings ({h.rows_held} rows), {h.rows_moving} rows "
            f"read while moving between them (a hand or a motor turning the sensor): "
            + ("their acceleration is no sensor effect" if ds.has_acc else
               "a magnetometer reads the field while it turns too, so they are readings like the held ones")
            + ("; label the holds' poses ([poses] in the sensor description) to fit against them"
               if not (have := [c for c in POSE_COLS if c in ds.columns]) else
               f"; the holds are found in the readings (the log's {' and '.join(have)} give their poses, not "
               f"where each begins)")), None,
            {"holds": h.count, "rows_held": h.rows_held, "rows_moving": h.rows_moving}))


def probe_range(ds, t: str) -> float | None:
    """The range of a dataset's triad t ("acc" in g, "mag" in nT): the
    declared one (acc_range_g, mag_range_nT), else the probe's own for a
    dataset of the probe (no imported sensor: the ADIS16210's +-1.7 g, the
    fluxgate's +-100 000 nT, docs/conventions.md), else None."""
    unit = "g" if t == "acc" else "nT"
    rng = ds.meta.get(f"{t}_range_{unit}")
    if rng:
        return float(rng)
    if ds.meta.get("sensor"):  # an imported log of another sensor: its description says, or nothing
        return None
    from inclino.engines import golden, reference as ref

    return golden.ACC_RANGE_COUNTS * ref.ACC_LSB_G if t == "acc" else golden.MAG_RANGE_COUNTS * ref.MAG_LSB_NT


def _saturation(ds, rep):
    """Rows at a triad's declared range (saturated), or beyond the probe's
    own range on a dataset of the probe that declares none (a reading the
    sensor cannot give: a garbled row, ax_g = 25 among 359 rows of 1 g, had
    the temperature terms dropped as "not what the model lacks"): left out
    of the fit, counted in a warning."""
    bad = np.zeros(len(ds), bool)
    for t, unit in (("acc", "g"), ("mag", "nT")):
        if not getattr(ds, f"has_{t}"):
            continue
        rng = probe_range(ds, t)
        if rng is None:
            continue
        declared = bool(ds.meta.get(f"{t}_range_{unit}"))
        v = np.abs(getattr(ds, t))
        hit = (v >= 0.999 * rng).any(1) if declared else (v > rng).any(1)
        if hit.any() and (declared or hit.mean() < 0.5):  # most rows beyond: a unit, which the units check names
            bad |= hit
            name = "accelerometer" if t == "acc" else "magnetometer"
            first = ", ".join(str(int(i) + 1) for i in np.flatnonzero(hit)[:5]) + (" ..." if hit.sum() > 5 else "")
            rep.findings.append(Finding("saturation", "warning", (
                f"{int(hit.sum())} row(s) at the {name}'s declared range +-{rng:g} {unit} (saturated): left out of "
                f"the fit" if declared else
                f"{int(hit.sum())} row(s) beyond the {name}'s range +-{f'{rng:.4f}'.rstrip('0').rstrip('.')} {unit} "
                f"(the probe's; the dataset "
                f"declares none), a reading the sensor cannot give (a garbled row?): left out of the fit (rows "
                f"{first})"), t, {"rows": int(hit.sum()), "range": rng, "declared": declared}))
    rep.saturated = np.flatnonzero(bad).tolist()


def _turning(ds, t, rep):
    """How fast the sensor turns between its moving rows, by the time column
    t (s): at the shortest lag L (1, 2, 4 ... 256 rows) where at least
    TURN_MIN_PAIRS pairs of rows (and 2 %) differ by TURN_NOISE_K times the
    triad's noise (the declared noise, else NOISE_BOUND) and by less than
    TURN_MAX_CHORD_DEG, the median of their angle over their time apart.
    The angle is the readings' difference over the vector's size (1 g, the
    field): offsets cancel in a difference.  The accelerometer when there is
    one (a magnetometer alone otherwise).  None on a log that does not turn,
    or whose consecutive rows jump by more than TURN_MAX_CHORD_DEG more
    often than they turn by less (its turns are not logged)."""
    tri = "acc" if ds.has_acc else "mag"
    unit = "g" if tri == "acc" else "nT"
    v = getattr(ds, tri)
    R = _vector_size(ds, tri)
    bound = rep.noise.get(f"{tri}_bound_{unit}") or NOISE_BOUND[tri]
    n = len(v)
    L = 1
    while L <= 256 and n > L + TURN_MIN_PAIRS:
        d = np.linalg.norm(v[L:] - v[:-L], axis=1) / R  # radians (chord of the unit sphere)
        dt = t[L:] - t[:-L]
        mov = (d > TURN_NOISE_K * bound / R) & (d < np.radians(TURN_MAX_CHORD_DEG)) & (dt > 0)
        if L == 1 and np.sum(d >= np.radians(TURN_MAX_CHORD_DEG)) > mov.sum():
            # more rows jump by more than TURN_MAX_CHORD_DEG than turn by less: the turns happen between the rows
            # (a turntable session, its moves not logged); pairs further apart would compare positions, not a
            # turn (ms declared s on 30 poses read 5-10 rows each, a row a second: "us" was named, from pairs
            # rows apart at positions that happened to lie within 30 deg of each other)
            return None
        if mov.sum() >= TURN_MIN_PAIRS and mov.mean() >= 0.02:
            ang = np.degrees(d[mov])
            return {"triad": tri, "lag_rows": L, "pairs": int(mov.sum()),
                    "deg_per_row": float(np.median(ang)) / L, "deg_per_s": float(np.median(ang / dt[mov]))}
        L *= 2
    return None


def _vector_size(ds, tri) -> float:
    """The size of the vector a triad reads: gravity (1 g, the header's
    gravity_g), the header's field_nT, else the readings' median |b| capped
    at the largest geomagnetic field (a hard-iron offset larger than the
    field, a phone's, would make every turn look small)."""
    if tri == "acc":
        return float(ds.meta.get("gravity_g") or 1.0)
    F = ds.meta.get("field_nT")
    if F:
        return float(F)
    b = float(np.median(np.linalg.norm(ds.mag, axis=1)))
    return min(b, GEOMAGNETIC_NT[1]) if np.isfinite(b) and b > 0 else 50_000.0


def _time_unit_text(ds, f: float):
    """What to write for a time column read f times the declared unit: the
    description's [log] time_unit or rate_hz, or None (no unit recorded)."""
    from inclino.formats import sensor

    meta = ds.meta
    if meta.get("rate_hz") and _imported(ds):
        return f"[log] rate_hz = {float(meta['rate_hz']) / f:.6g}", f"{float(meta['rate_hz']) / f:.6g} Hz"
    declared = meta.get("time_unit") if _imported(ds) else "s"
    if not declared or declared == "date-time":
        return None
    try:
        scale = sensor.time_scale(declared) * f
    except DataError:
        return None
    units = sensor.TIME_UNITS | sensor.TICK_UNITS
    names = [k for k, x in units.items() if k != "µs" and abs(x / scale - 1.0) < 1e-9]
    name = names[0] if names else (f"1/{1.0 / scale:.6g} s" if scale < 1.0 else f"{scale:.6g} s")
    return f'[log] time_unit = "{name}" (declared "{declared}")', name


def _time_factors(ds) -> list:
    """The factors (x the declared unit) _time_unit tries, in order: those
    to a unit sensor.TIME_UNITS names, first in TIME_FACTORS' order and then
    the other named units nearest first (a tick of sensor.TICK_UNITS among
    them: a 10 kHz counter of 100 us ticks), then the rest of TIME_FACTORS.  A
    named unit is the likelier slip: ms declared as min read 60 000x slow,
    and 0.06 s (1e-3 x min, first in TIME_FACTORS) made the rows and the
    turning as plausible as ms did, so "1/16.6667 s" was named (a hand-turned
    BNO055, imported 12x fast when followed)."""
    from inclino.formats import sensor

    declared = ds.meta.get("time_unit") if _imported(ds) else "s"
    try:
        scale = sensor.time_scale(declared) if declared and declared != "date-time" else None
    except DataError:
        scale = None
    units = [x for k, x in (sensor.TIME_UNITS | sensor.TICK_UNITS).items() if k != "µs"]

    def same(a, b):
        return abs(a / b - 1.0) < 1e-9
    if scale is None or not any(same(x, scale) for x in units):
        return list(TIME_FACTORS)  # a sample period ("1/102.4 s") or no unit: the prefixes and minutes only
    named = [f for f in TIME_FACTORS if any(same(x, scale * f) for x in units)]
    more = sorted((x / scale for x in units if not same(x, scale) and not any(same(x, scale * f) for f in named)),
                  key=lambda f: abs(np.log(f)))
    return named + more + [f for f in TIME_FACTORS if f not in named]


def _unix_time_slow(ds, t, rep) -> bool:
    """A time column read in too large a unit, where its clock tells:
    the first row's time beyond UNIX_S[1] (a clock counting from 1970 there
    is decades ahead; no logger's clock counts so far from any start),
    which a unit 1000, 10^6 or 10^9 times smaller makes a Unix time within
    UNIX_S (2000-2040): the log's clock is Unix time in that unit.  A finding
    (warning), True when made.  The turning and the row rate cannot tell it
    on a static log or a log of holds (each row read at rest: a row every
    4 s is a plausible logger, 5 deg a row at 1.3 deg/s a plausible rig):
    AirbrakesV2's MicroStrain CX5 stamps rows in Unix ns, and declared "us"
    it imported with every row 1000x further apart in silence.  Only this
    side: a column too small for a Unix time in the declared unit (1e6 s)
    is as often an uptime counter, which a Unix time in another unit
    cannot be told from."""
    import datetime

    t0 = float(t[0])
    if not np.isfinite(t0) or t0 <= UNIX_S[1]:
        return False
    for f in (1e-3, 1e-6, 1e-9):
        if UNIX_S[0] <= t0 * f <= UNIX_S[1]:
            break
    else:
        return False
    fix = _time_unit_text(ds, f)
    when = datetime.datetime.fromtimestamp(t0 * f, datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    years = t0 / (365.25 * 86400.0)
    read = f"as {fix[1]}" if fix is not None else f"{1 / f:g}x smaller"
    what = "declared rate_hz" if ds.meta.get("rate_hz") and _imported(ds) else "time column's unit"
    msg = (f"the {what} does not fit the rows: the first row's time is {t0:.4g} s, {years:.3g} years after 1970 "
           f"(no clock counts so far), while read {read} it is {when}: the log's clock is "
           f"Unix time in that unit, every row {1 / f:g}x further apart than it was logged; "
           + (f"fix {fix[0]} in the sensor description and import again" if fix and _imported(ds) else
              f"t_s must be in seconds: {_fix(ds, 'log', 'the time unit')}")
           + " (the drift over the session, the rates and any lag in seconds use it)")
    fig = {"first_time_s": t0, "factor": f, "unix_time_s": t0 * f}
    if fix is not None:
        fig["looks_like"] = fix[1]
    rep.time = {**(rep.time or {}), **fig}
    rep.findings.append(Finding("time", "warning", msg, None, fig))
    return True


def _temp_rate(ds, t):
    """How fast the temperature column changes against the time column t
    (degC/s): on each run of rows in time order (a joined log is cut where
    its time goes back) of at least TEMP_RATE_MIN_ROWS rows, the slope of a
    straight line through temp_c against t_s, kept when it stands
    TEMP_RATE_SIGNIF standard errors from zero (a trend, not the
    resolution's noise); their median |slope|, or None."""
    T = ds.columns.get("temp_c")
    if T is None or len(T) != len(t):
        return None
    T = np.asarray(T, float)
    cuts = np.flatnonzero(np.diff(t) < 0) + 1
    rates = []
    for seg in np.split(np.arange(len(t)), cuts):
        ts, Ts = t[seg], T[seg]
        ok = np.isfinite(ts) & np.isfinite(Ts)
        ts, Ts = ts[ok], Ts[ok]
        if len(ts) < TEMP_RATE_MIN_ROWS or not np.ptp(ts) > 0.0 or not np.ptp(Ts) > 0.0:
            continue
        tc = ts - ts.mean()
        sxx = float(tc @ tc)
        b = float(tc @ (Ts - Ts.mean())) / sxx
        res = Ts - Ts.mean() - b * tc
        se = float(np.sqrt(res @ res / (len(ts) - 2) / sxx))
        if abs(b) > TEMP_RATE_SIGNIF * se:
            rates.append(abs(b))
    return float(np.median(rates)) if rates else None


def _time_unit(ds, rep):
    """The time column's unit against the physics of the rows it dates: the
    row rate it implies (ROW_RATE_HZ: no logger writes a row per sample
    faster than 100 kHz; a row every 10 min is no log of a moving sensor)
    and the rate the sensor turns at between its moving rows
    (TURN_RATE_DEG_S: a hand or a rig turns a sensor at 1-5000 deg/s, not
    10^5 or 0.01 deg/s while the rows turn by degrees).  A time column in
    ms declared as s (or s as ms) is off 1000x in both.  The finding names
    the unit (_time_factors x the declared one) that brings both within
    what loggers and hands do (TYPICAL_*), and what to write.  A warning; an
    error beyond TURN_RATE_MAX_DEG_S.  The slow side only on an imported log
    not declared static: the rows of a turntable run (each a position read at
    rest, minutes apart) turn by degrees a row at any rate; the project's own
    runs write t_s in seconds from their clock.  On an imported log the
    temperature's rate too (_temp_rate: faster than TEMP_RATE_MAX_C_S is the
    time unit too small), which tells where the turning cannot: a static log."""
    t = ds.columns.get("t_s")
    if t is None or len(ds) < 10:
        return
    t = np.asarray(t, float)
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    still, went_back = float(np.mean(dt == 0)), len(back) / len(dt)
    if still > NOT_TIME_STILL and went_back > NOT_TIME_BACK:
        # a clock steps forward (a slow one repeats, a joined log goes back a few times): a column that mostly
        # stands and often goes back is a reading (a barometer's pressure mapped as the time was given a unit)
        rep.findings.append(Finding("time", "warning", (
            f"the time column does not look like a time: {100 * still:.0f} % of its steps are zero and "
            f"{100 * went_back:.0f} % go back (a clock steps forward): another column mapped as the time? "
            + _fix(ds, "log", "the time column ([log] time, or rate_hz)")), None,
            {"steps_zero": still, "steps_back": went_back}))
        return
    if len(back):
        # files joined one after another, each timed from its own start: the rows are read as they stand, but a
        # plot or a drift against time overlays the runs (a six-face session joined from six files)
        rep.findings.append(Finding("time-order", "note", (
            f"the time column goes back {len(back)} time{'s' if len(back) > 1 else ''} (first after row "
            f"{int(back[0]) + 1}, from {t[back[0]]:.6g} to {t[back[0] + 1]:.6g} s): the rows are out of time order "
            f"(runs joined one after another, each timed from its own start, or parts of one run rearranged); they "
            f"are used as they stand, and what is plotted or tested against time overlays them"), None,
            {"time_back_rows": [int(i) + 1 for i in back[:20]]}))
    if _unix_time_slow(ds, t, rep):
        return
    pos = dt[dt > 0]
    if len(pos) < 5:
        return
    rows_hz = 1.0 / float(np.median(pos))
    static = rep.declared_static or declared_static(ds)
    turn = None if static else _turning(ds, t, rep)
    w = turn["deg_per_s"] if turn else None
    # the temperature tells where the turning cannot (a static log, its rows read at rest): an MPU-6050's millis()
    # declared "us", six faces held 30 s each, read as 62 500 rows/s, had imported in silence
    # (an imported log's only: the project's own runs write t_s from their clock, and a generated one steps its
    # chamber's set points a row apart)
    temp_rate = _temp_rate(ds, t) if _imported(ds) else None
    fig = {"rows_per_s": rows_hz, "turn_deg_s": w, "turn": turn}
    if temp_rate is not None:
        fig["temp_rate_c_s"] = temp_rate
    rep.time = fig
    problem = None
    if w is not None and w > TURN_RATE_DEG_S[1]:
        problem, sign = (f"the readings turn at a median {w:.3g} deg/s between their moving rows "
                         f"({turn['deg_per_row']:.2g} deg a row, {rows_hz:.3g} rows/s): faster than a hand or a rig "
                         f"turns a sensor ({TURN_RATE_DEG_S[0]:g}-{TURN_RATE_DEG_S[1]:g} deg/s)"), 1
    elif w is not None and w < TURN_RATE_DEG_S[0] and turn["deg_per_row"] >= TURN_MIN_DEG_ROW and _imported(ds):
        problem, sign = (f"the readings turn by {turn['deg_per_row']:.2g} deg a row but at a median {w:.3g} deg/s "
                         f"({rows_hz:.3g} rows/s, a row every {1.0 / rows_hz:.3g} s): slower than a hand or a rig "
                         f"turns a sensor ({TURN_RATE_DEG_S[0]:g}-{TURN_RATE_DEG_S[1]:g} deg/s) while its rows change "
                         f"by degrees (a log of one row a position, each read at rest: declare it static)"), -1
    elif temp_rate is not None and temp_rate > TEMP_RATE_MAX_C_S:
        problem, sign = (f"the temperature changes at a median {temp_rate:.3g} degC/s along its runs of rows "
                         f"({rows_hz:.3g} rows/s): faster than a sensor's temperature moves (up to "
                         f"{TEMP_RATE_MAX_C_S:g} degC/s), unless [log] temperature is no temperature"), 1
    elif rows_hz > ROW_RATE_HZ[1]:
        problem, sign = (f"{rows_hz:.3g} rows/s (a row every {1e6 / rows_hz:.3g} us): faster than a logger writes "
                         f"a row per sample (up to {ROW_RATE_HZ[1]:.0f} rows/s)"), 1
    elif rows_hz < ROW_RATE_HZ[0] and turn is not None and _imported(ds):
        problem, sign = (f"a row every {1.0 / rows_hz:.3g} s on a log whose readings turn between rows: slower than "
                         f"a logger of a moving sensor writes"), -1
    if problem is None:
        return
    fits = _unit_fits(ds, sign, rows_hz, w, temp_rate)
    guess = fits[0] if fits else None
    level = "error" if w is not None and w > TURN_RATE_MAX_DEG_S else "warning"
    rate = ds.meta.get("rate_hz") and _imported(ds)
    what = "declared rate_hz" if rate else "time column's unit"
    msg = f"the {what} does not fit the rows: {problem}"
    if rate and w is not None:
        # a rate is no unit: nothing says it is 1000x off rather than 100x (an FXOS8700 at 10 Hz declared
        # 1000 was told "rate_hz = 1"); the rates that make the turning a hand's or a rig's are said instead
        r = float(ds.meta["rate_hz"])
        lo = max(r * TYPICAL_TURN_DEG_S[0] / w, TYPICAL_ROW_RATE_HZ[0])
        hi = min(r * TYPICAL_TURN_DEG_S[1] / w, TYPICAL_ROW_RATE_HZ[1])
        fig["rate_hz_range"] = [lo, hi]
        slip = ""
        if guess is not None and guess in (1e3, 1e-3) and lo <= r / guess <= hi \
                and not TYPICAL_ROW_RATE_HZ[0] <= r <= TYPICAL_ROW_RATE_HZ[1]:
            # (a declared rate no logger runs at: a prefix slip the likelier; within them, nothing tells)
            fig["looks_like"] = f"{r / guess:.6g} Hz"
            slip = (f" (rate_hz = {r / guess:.6g}, {'1000x less' if guess > 1 else '1000x more'}, is among them: "
                    f"{'kHz read as Hz' if guess > 1 else 'Hz read as kHz'}?)")
        msg += (f"; at {lo:.3g} to {hi:.3g} Hz the sensor would turn at {TYPICAL_TURN_DEG_S[0]:g}-"
                f"{TYPICAL_TURN_DEG_S[1]:g} deg/s{slip}: check [log] rate_hz against the logger's setting (the "
                f"drift over the session, the rates and any lag in seconds use it)") if lo < hi else \
            "; check [log] rate_hz against the logger's setting"
    elif guess is not None:
        fig["factor"] = guess
        fix = _time_unit_text(ds, guess)
        msg += "; " + ", or ".join(_read_as(ds, f, rows_hz, w, temp_rate) for f in fits)
        also = [_time_unit_text(ds, f) for f in fits[1:]]
        if len(fits) > 1:
            msg += ": nothing in the rows tells these apart, the logger's documentation does"
        msg += ("; " + (f"fix {fix[0]}" + "".join(f', or "{a[1]}"' for a in also if a) +
                        " in the sensor description and import again" if fix and _imported(ds) else
                        f"t_s must be in seconds: {_fix(ds, 'log', 'the time unit')}")
                + " (the drift over the session, the rates and any lag in seconds use it)")
        if fix is not None:
            fig["looks_like"] = fix[1]
        if len(fits) > 1:
            fig["also_fits"] = [a[1] if a else f for a, f in zip(also, fits[1:])]
    else:
        msg += ("; check the time unit ([log] time_unit, or rate_hz): the drift over the session, the rates and any "
                "lag in seconds use it")
    rep.findings.append(Finding("time", level, msg, None, fig))


def _unit_fits(ds, sign: int, rows_hz: float, w, temp_rate) -> list:
    """The factors (x the declared unit) to name: of those that bring the
    row rate, the turning and the temperature's rate within what loggers
    and hands do (TYPICAL_*; _time_factors' order, on the side `sign` says:
    > 1 when the rows read too fast), the first, and after it the others
    that give a unit people log in (_named_unit: never a factor such as
    1/3600 x s).  Where the turning is known, those that put it where the
    corpus' moving logs turn (TURN_SEEN_DEG_S), else the first alone: a
    100 us tick counter declared us turns at 33 deg/s read as ms, 10x slower
    than any of them, and at 334 deg/s read as 100 us (x-io's log written as
    an Xsens export); where two units both put it there, both are named.
    Without the turning (a static log) every such unit the row rate and the
    temperature's allow: nothing tells them apart."""
    fits = []
    for f in _time_factors(ds):
        if (f > 1) != (sign > 0):
            continue
        ok = TYPICAL_ROW_RATE_HZ[0] <= rows_hz / f <= TYPICAL_ROW_RATE_HZ[1]
        if w is not None:
            ok = ok and TYPICAL_TURN_DEG_S[0] <= w / f <= TYPICAL_TURN_DEG_S[1]
        if temp_rate is not None:
            ok = ok and temp_rate / f <= TEMP_RATE_TYPICAL_C_S
        if ok:
            fits.append(f)
    named = fits[:1] + [f for f in fits[1:] if _named_unit(ds, f)]
    if w is None:
        return named
    seen = [f for f in named if TURN_SEEN_DEG_S[0] <= w / f <= TURN_SEEN_DEG_S[1]]
    return seen or fits[:1]


def _named_unit(ds, f: float) -> bool:
    """Whether f x the declared unit is a unit of sensor.TIME_UNITS or
    TICK_UNITS (not a sample period such as "1/3600 s")."""
    fix = _time_unit_text(ds, f)
    return fix is not None and not fix[1].endswith(" s")


def _read_as(ds, f: float, rows_hz: float, w, temp_rate) -> str:
    """'read as ms: 14.3 rows/s, 99.6 deg/s': the rows' figures in the unit f
    times the declared one."""
    fix = _time_unit_text(ds, f)
    read = (f"read {f:g}x slower: " if f > 1 else f"read {1 / f:g}x faster: ") if fix is None else \
        f"read as {fix[1]}: "
    return (f"{read}{rows_hz / f:.3g} rows/s" + (f", {w / f:.3g} deg/s" if w is not None else "")
            + (f", the temperature {temp_rate / f:.3g} degC/s" if temp_rate is not None else ""))


def not_a_temperature(ds) -> tuple | None:
    """Why a temp_c column cannot be a temperature, or None: it equals a
    pose angle or a sensor axis up to a scale and an offset within
    TEMP_EXACT of its range on every row (the description maps [log]
    temperature to the wrong column).  A temperature exactly linear in the
    time, or stepping by exactly the same amount every row, is not refused
    (temperature_ramp: a simulated chamber ramp reads so).  (reason,
    figures)."""
    names = {"inc_deg": "the pose's inc_deg", "azi_deg": "the pose's azi_deg", "tf_deg": "the pose's tf_deg",
             **{c: f"the sensor column {c}" for c in ("ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT")}}
    return _temp_equals(ds, names)


def _temp_changing(ds, min_rows: int):
    """(temp_c, its span) when the column has at least min_rows rows and
    changes; else None."""
    T = ds.columns.get("temp_c")
    if T is None or len(T) < min_rows:
        return None
    T = np.asarray(T, float)
    span = float(np.ptp(T))
    return (T, span) if span > 0.0 else None


def _temp_equals(ds, names: dict):
    """not_a_temperature's test against the named columns."""
    got = _temp_changing(ds, 3)
    if got is None:
        return None
    T, span = got
    for c, text in names.items():
        x = ds.columns.get(c)
        if x is None:
            continue
        x = np.asarray(x, float)
        if not np.ptp(x) > 0.0:
            continue
        A = np.column_stack([x, np.ones_like(x)])
        coef = np.linalg.lstsq(A, T, rcond=None)[0]
        if float(np.max(np.abs(T - A @ coef))) <= TEMP_EXACT * span:
            return (f"it is {text} up to a scale and an offset on every row (temp_c = {coef[0]:.6g} x {c} "
                    f"{coef[1]:+.6g})"), {"equals": c}
    return None


def temperature_ramp(ds) -> tuple | None:
    """A temp_c exactly linear in the time t_s, or stepping by exactly the
    same amount every row: a simulated ramp, or a clock or a row counter
    mapped as the temperature (the data cannot tell which: a note, the
    column is used).  (reason, figures) or None."""
    got = _temp_changing(ds, 10)
    if got is None:
        return None
    T, span = got
    same = _temp_equals(ds, {"t_s": "the time t_s"})
    if same is not None:
        return same
    d = np.diff(T)
    if np.ptp(d) <= TEMP_EXACT * span and d[0] != 0.0:
        return (f"it steps by exactly {d[0]:g} every row, {T[0]:g} to {T[-1]:g}"), {"step": float(d[0])}
    return None


def _temperature(ds, rep):
    """A temp_c column that determines nothing or cannot be a temperature:
    one value on every row (a note: no temperature terms can be fitted from
    it; calibrate's own note says it fitted none), or not_a_temperature: an
    error for an imported log (the description maps [log] temperature to the
    wrong column: nothing is written), a note for a canonical dataset, whose
    temp_c `calibrate` and `diagnose` then leave out (calib.thermal,
    diagnose.analysis)."""
    T = ds.columns.get("temp_c")
    if T is None or len(T) < 3:
        return
    T = np.asarray(T, float)
    col = "the [log] temperature column" if _imported(ds) else "temp_c"
    if float(np.ptp(T)) == 0.0:
        rep.findings.append(Finding("temperature", "note", (
            f"temp_c is {T[0]:g} degC on every row: a temperature that never changes determines no temperature "
            f"terms (calibrate fits none: they need the run to span at least 10 degC, a chamber run) and diagnose "
            f"tests no temperature effect; if the log's temperature changes, {col} is not it"),
            None, {"temp_c": float(T[0])}))
        return
    bad = not_a_temperature(ds)
    if bad is None:
        ramp = temperature_ramp(ds)
        if ramp is not None:
            rep.findings.append(Finding("temperature", "note", (
                f"temp_c rises exactly linearly: {ramp[0]}: a simulated ramp, or a clock or a row counter mapped "
                f"as the temperature ({col}); it is used as the temperature"), None, ramp[1]))
        return
    why, fig = bad
    if _imported(ds):
        rep.findings.append(Finding("temperature", "error", (
            f"temp_c does not look like a temperature: {why}; "
            f"{_fix(ds, 'log', 'the temperature column (or leave it out)')}"), None, fig))
    else:
        rep.findings.append(Finding("temperature", "note", (
            f"temp_c does not look like a temperature: {why}; calibrate and diagnose leave it out"), None, fig))


def one_orientation(ds) -> dict | None:
    """Whether every row reads one orientation (the sensor held still): the
    readings of each triad within ONE_ORIENTATION_DEG of their median (95 %
    of the rows; the difference of two readings over the vector's size is
    the angle turned, whatever the offsets).  {triad: spread (deg)} or None."""
    if len(ds) < 2:
        return None
    out = {}
    for tri in ("acc", "mag"):
        if not getattr(ds, f"has_{tri}"):
            continue
        v = np.asarray(getattr(ds, tri), float)
        d = np.linalg.norm(v - np.median(v, axis=0), axis=1) / _vector_size(ds, tri)
        spread = float(np.degrees(np.percentile(d, 95)))
        if not np.isfinite(spread) or spread >= ONE_ORIENTATION_DEG:
            return None
        out[tri] = spread
    return out or None


def undetermined(fig: dict, rows: int) -> str:
    """The one line that says one orientation determines no model, and what
    to record instead (diagnose refuses with it, exit 2; calibrate as a singular
    fit, exit 3)."""
    spread = ", ".join(f"{'accelerometer' if k == 'acc' else 'magnetometer'} {v:.2g} deg" for k, v in fig.items())
    return (f"every row reads one orientation ({rows} rows within {spread} of their median direction: the sensor "
            f"held still, or turned only about the vector it reads): the data do "
            f"not determine the model (a triad's scale, offsets and axes show only as the sensor turns); record the "
            f"sensor held still at 12 or more orientations spread over the sphere (six faces and the diagonals "
            f"between), or turned slowly through all of it; a log at one orientation gives the noise and drift there")


def _orientations(ds, rep):
    """Every row one orientation: a note here (a log of the noise at rest is
    a log worth importing); calibrate and diagnose refuse it (undetermined)."""
    fig = one_orientation(ds)
    rep.one_orientation = fig
    if fig:
        rep.findings.append(Finding("orientations", "note", undetermined(fig, len(ds)), None, dict(fig)))


def corrected(meta: dict, gt=None, bt=None, dip=None, cal: str = "the calibration") -> Finding | None:
    """After a calibration is applied (`attitude --cal`): the corrected
    readings' median |g| against the header's gravity_g (1 g), their median
    |b| and dip against the header's field_nT and dip_deg when given (|b|
    against the geomagnetic range when not), with the pre-fit checks'
    tolerances (GRAVITY_TOL, FIELD_TOL, DIP_MISMATCH_DEG).  A calibration
    of this sensor brings them within a few % and a few degrees; one of
    another sensor, or a stale one, does not.  One warning (or None) naming
    every figure out of its tolerance."""
    bad, fig = [], {}

    def med(x):
        x = np.asarray(x, float)
        x = x[np.isfinite(x)]
        return float(np.median(x)) if x.size else None

    G = float(meta.get("gravity_g") or 1.0)
    g = med(gt) if gt is not None else None
    if g is not None:
        fig.update(median_g=g, expected_g=G)
        if not GRAVITY_TOL[0] <= g / G <= GRAVITY_TOL[1]:
            bad.append(f"|g| {g:.4g} g against {G:g} g ({100 * (g / G - 1):+.0f} %)")
    b = med(bt) if bt is not None else None
    F = meta.get("field_nT")
    if b is not None:
        fig["median_b_nT"] = b
        if F:
            fig["header_field_nT"] = float(F)
            if not FIELD_TOL[0] <= b / float(F) <= FIELD_TOL[1]:
                bad.append(f"|b| {b:.0f} nT against the header's field_nT {float(F):g} ({100 * (b / float(F) - 1):+.0f} %)")
        elif not GEOMAGNETIC_NT[0] <= b <= GEOMAGNETIC_NT[1]:
            bad.append(f"|b| {b:.0f} nT, outside the geomagnetic range {GEOMAGNETIC_NT[0]:.0f}-{GEOMAGNETIC_NT[1]:.0f} nT")
    d = med(dip) if dip is not None else None
    D = meta.get("dip_deg")
    if d is not None and D is not None:
        fig.update(dip_deg=d, header_dip_deg=float(D))
        if abs(d - float(D)) > DIP_MISMATCH_DEG:
            bad.append(f"dip {d:+.1f} deg against the header's {float(D):+.1f}")
    if not bad:
        return None
    magnetic = any(x.startswith(("|b|", "dip")) for x in bad)
    hdr = [k for k, x in (("gravity_g", "|g|"), ("field_nT", "|b|"), ("dip_deg", "dip"))
           if meta.get(k) is not None and any(y.startswith(x) for y in bad)]
    return Finding("calibration", "warning", (
        f"after {cal}, the corrected readings' median " + ", ".join(bad) + ": a calibration of another sensor or a "
        f"stale one (the sensor changed since)" + (f", wrong header values ({', '.join(hdr)})" if hdr else "")
        + (", or a magnetic disturbance at the site" if magnetic else "") + "; the rows are computed"), None, fig)


def run(ds, declared_static: bool = False) -> CheckReport:
    """Every check that the dataset's columns allow (docs/dataset.md)."""
    rep = CheckReport(rows=len(ds), triads=ds.triads, declared_static=bool(declared_static))
    rows = _thin(len(ds), CHECK_ROWS)
    with np.errstate(all="ignore"):
        if ds.has_acc:
            _units_acc(ds, rows, rep)
        if ds.has_mag:
            _units_mag(ds, rows, rep)
        units_bad = any(f.check == "units" and f.level == "error" for f in rep.findings)
        _orientations(ds, rep)  # before the pairing: a shift changes nothing on one orientation
        gp = None
        if ds.has_acc and "inc_deg" in ds.columns and "tf_deg" in ds.columns and not units_bad and len(ds) >= 6:
            gp = _acc_poses(ds, rows, rep)
        if not units_bad and len(ds) >= 6:
            if ds.has_acc and not ds.has_mag and gp is None:
                rep.findings.append(Finding("dip-sign", "note", (
                    "the accelerometer's gravity sign was not checked: without poses or a magnetometer (and the "
                    "site's dip) nothing in the readings tells up from down, and a sign turned on every axis "
                    "(reads = \"up\" or \"down\") calibrates as well, every inclination then read as 180 deg less "
                    "it; check one row against a known orientation (an axis pointing down must read +1 g)"),
                    "acc", {}))
            poses = "inc_deg" in ds.columns and "tf_deg" in ds.columns
            if ds.has_acc != ds.has_mag and not poses:
                name = "accelerometer" if ds.has_acc else "magnetometer"
                rep.findings.append(Finding("handedness", "note", (
                    f"the {name}'s axis map was not checked for a mirror: one triad without poses reads a mirrored "
                    f"axis as a mirrored world, every reading's magnitude the same, and the fit cannot tell; "
                    f"check the map against the part's axis drawing (a right-handed x, y, z)"),
                    "acc" if ds.has_acc else "mag", {}))
            if ds.has_acc and ds.has_mag:
                _axes_and_lag(ds, rows, rep)
            elif ds.has_mag and "inc_deg" in ds.columns and "tf_deg" in ds.columns:
                from inclino.engines import reference as ref

                C = ref.pose_matrix(ds.columns["inc_deg"], ds.columns.get("azi_deg", np.zeros(len(ds))),
                                    ds.columns["tf_deg"])
                _axes_and_lag(ds, rows, rep, ug_src=C[:, :, 2])
        _motion(ds, rep)
        _saturation(ds, rep)
        _time_unit(ds, rep)
        _temperature(ds, rep)
    return rep
