"""Static holds in a log without poses: the readings' own stillness.

A step-and-hold log (a six-face session, a gimbal that stops at each
position, a tool held still at each station) reads hundreds of rows at one
orientation, and often moves by hand or by motor between orientations.  When
the log has no pose or pose-id column, nothing says which rows belong
together.  The rows of one hold share that orientation's error and any slow
drift, so they are one pose, not hundreds of independent ones; and the rows
read while moving carry the motion's own acceleration, which no sensor model
explains.

`find(ds)` marks a row as still when every window of HOLD_ROWS consecutive
rows around it has, on every axis of every triad present, a standard
deviation within HOLD_K times that axis's noise; a hold is then a run of
still rows at least HOLD_ROWS long, cut where its direction turns by more
than HOLD_TURN_DEG from where the run began (a slow turn is not a hold), and
between two rows that differ by more than HOLD_JUMP_K times their noise on
an axis (an abrupt change: the next face, with nothing read in between),
and where a partial pose column (a face label, a rig axis's setting)
changes: a hold is at one setting (a column that changes on most rows is
a variable read with each row, not a setting: setting_changes).
The noise per axis is the readings' own: the median absolute difference of
neighbouring rows (/ 0.6745 / sqrt 2), a statistic that the still rows set
when they are the majority (else, where the windows' lowest tenth is a
tenth of the median or less and 30 % of the windows are quiet at it, that
lowest tenth read as a still window's spread: _noise); it is capped at the
triad's declared noise, or
at NOISE_BOUND (the most a part of that kind has), so that a log that
moves all the time is not read as still; and floored at the resolution's
quantisation noise (LSB / sqrt 12).

One short stop in a direction no other hold has, whose leverage alone
keeps the holds from determining the model while the others determine it
without it, is set aside with the rows read while moving
(_lone_stop_aside).

A log is read as step-and-hold when its holds hold at least
STEP_AND_HOLD_FRACTION of the rows; otherwise (a log turned continuously by
hand) the holds are not used.  Callers: diagnose's pose-free mode
(diagnose/posefree.py), docs/diagnose.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from inclino.formats.dataset import ID_COLUMNS, POSE_COLS

# the noise (1 sigma, one reading, per axis) a static sensor of each kind stays within when the
# description gives none: MEMS accelerometers 100-300 ug/sqrt(Hz) over a few hundred Hz (<= 5 mg);
# MEMS magnetometers 0.15-0.6 uT per LSB (<= 1 uT); the fluxgate a few nT
NOISE_BOUND = {"acc": 5e-3, "mag": 1000.0}  # g, nT
HOLD_ROWS = 10                 # a hold is at least this many consecutive still rows (and the window's length)
HOLD_K = 3.0                   # a still window's per-axis standard deviation: at most this many times the noise
HOLD_TURN_DEG = 0.5            # a run whose direction turns by more than this from its start is cut there
TREND_SPAN = 8 * HOLD_ROWS     # ... fitted in stretches of this many rows
TREND_CHI2 = 16.3              # a run's fitted turn (3 components) this many squared standard errors off 0: steady
HOLD_JUMP_K = 6.0              # neighbouring rows differing by this many times their noise on an axis: a new hold
STEP_AND_HOLD_FRACTION = 0.5   # holds must hold this share of the rows for a log to be read as step-and-hold
HOLDS_MAX_LEVERAGE = 0.8       # the holds alone determine a triad's ellipsoid when no hold's leverage exceeds this
HOLDS_CENTRE_FRAC = 0.25       # holds' directions taken from the sphere's centre when it is this far off (its radius)
HOLDS_FREE_SV = 0.02           # ... and no term is nearly free: the holds' directions' least singular value over the
                               # largest (undetermined_text; a phone's holds all in the x-z and y-z planes: 0.004)
LONE_HOLD_MAX_ROWS = 3 * HOLD_ROWS  # a hold this short that alone keeps the others from determining is set aside
ONE_AXIS_DEG = 20.0            # holds all within this of one axis are said to be (undetermined_text)
MIN_HOLDS = 12                 # a step-and-hold log's holds are used as its poses from this many on


@dataclass
class Holds:
    """labels: (n,) the hold of each row (0 .. count-1), -1 for a row read
    while moving; noise: per triad the per-axis noise used (g, nT)."""
    labels: np.ndarray
    count: int
    rows_held: int
    rows_moving: int
    noise: dict
    set_aside: list = field(default_factory=list)  # [{"rows": [first, last], "leverage": ...}] (lone stops)

    @property
    def step_and_hold(self) -> bool:
        n = self.rows_held + self.rows_moving
        return self.count >= 2 and n > 0 and self.rows_held >= STEP_AND_HOLD_FRACTION * n

    def to_dict(self) -> dict:
        return {"holds": self.count, "rows_held": self.rows_held, "rows_moving": self.rows_moving,
                "step_and_hold": self.step_and_hold, "hold_rows_min": HOLD_ROWS, "hold_k": HOLD_K,
                "hold_turn_deg": HOLD_TURN_DEG,
                "noise": {k: [float(x) for x in v] for k, v in self.noise.items()},
                "set_aside": list(self.set_aside)}


_CHI2_10 = 4.168159  # chi-square's 10 % point at HOLD_ROWS - 1 = 9 degrees of freedom
MINORITY_RATIO = 10.0  # the median window's spread over the lowest tenth's, from which the still windows may be few
STILL_MINORITY = 0.3   # ... and the share of windows quiet at the lowest tenth's spread needed to say so


def _noise(ws, declared, lsb, bound) -> np.ndarray:
    """Per axis: the median window standard deviation (the still windows'
    when they are the majority; a quantised reading's median difference of
    neighbours would be one LSB or zero), capped at the declared noise (else
    bound), floored at LSB / sqrt 12."""
    s = np.median(ws, axis=0)
    if len(ws) >= 10 * HOLD_ROWS:
        # the median is a still window's only when the still windows are the majority.  Held 30 rows
        # between turns of 20, 21 of every 50 ten-row windows lie wholly in a hold: the median window
        # moves (900 nT against 5 nT of noise), the rows at either end of each turn pass as still and
        # the holds' means carry part of the turn.  Where the windows' lowest tenth, read as a still
        # window's spread, is a tenth of the median or less on every axis and at least
        # STILL_MINORITY of the windows are quiet at it, the still windows are that minority and set
        # the noise (quantised or merely quieter windows of a log held most of the time -- the corpus
        # logs -- leave the ratio below 10 or only a few windows quiet at it)
        q = np.quantile(ws, 0.1, axis=0) / math.sqrt(_CHI2_10 / (HOLD_ROWS - 1))
        if np.all(q * MINORITY_RATIO <= s) and np.mean(np.all(ws <= HOLD_K * q, axis=1)) >= STILL_MINORITY:
            s = q
    cap = float(declared) if declared else bound
    floor = float(lsb) / math.sqrt(12.0) if lsb else 0.0
    return np.maximum(np.minimum(s, cap), max(floor, 1e-12))


def _window_std(v, w) -> np.ndarray:
    """(n - w + 1, 3): each window's per-axis standard deviation (cumulative
    sums, centred on the log's mean so that large offsets cost no digits)."""
    x = v - v.mean(axis=0)
    c1 = np.concatenate([np.zeros((1, 3)), np.cumsum(x, axis=0)])
    c2 = np.concatenate([np.zeros((1, 3)), np.cumsum(x * x, axis=0)])
    s1 = c1[w:] - c1[:-w]
    s2 = c2[w:] - c2[:-w]
    var = np.maximum(s2 / w - (s1 / w) ** 2, 0.0) * w / (w - 1)
    return np.sqrt(var)


def _first_turn(m, i, b, anchor, cos_turn) -> int:
    """The first window start k in [i, b - HOLD_ROWS] whose mean direction m[k]
    is off the anchor by more than the turn; the cut is at its last row, the
    first that the window's mean can have turned with (b if none).  Looked
    for in doubling stretches: linear time."""
    step = 4 * HOLD_ROWS
    lo, last = i, b - HOLD_ROWS + 1
    while lo < last:
        hi = min(last, lo + step)
        turned = np.flatnonzero(m[lo:hi] @ anchor < cos_turn)
        if len(turned):
            return lo + int(turned[0]) + HOLD_ROWS - 1
        lo, step = hi, 2 * step
    return b


def _size(ds, t, v) -> float:
    """The size of the vector a triad reads: gravity (gravity_g, 1 g), the
    header's field_nT, else the median size of the readings as the holds
    turn them (_centred)."""
    if t == "acc":
        return float(ds.meta.get("gravity_g") or 1.0)
    return float(ds.meta.get("field_nT") or np.median(np.linalg.norm(v, axis=1)) or 1.0)


class _Trend:
    """The steady turn of a run of rows: the least-squares line through
    their unit directions against the row (prefix sums: constant time a
    run), the readings taken over the vector's size (an offset cancels
    in their change) and their change across the run's mean reading.  A window's mean direction lags its rows, so a run cut where the
    window means turn by HOLD_TURN_DEG spans HOLD_ROWS - 1 rows more than
    that: a run turning steadily (a sensor turned slowly by hand) is cut
    into runs of HOLD_ROWS + 1 rows that each turn by up to 10x the
    rate at which the window means turn HOLD_TURN_DEG (0.3 deg a row: 3 deg
    a "hold").  `end(i, j)` is the end of the stretch from row i that
    turns by no more than HOLD_TURN_DEG at the run's fitted rate, when the
    rows i .. j - 1 turn steadily (beyond HOLD_TURN_DEG and beyond
    TREND_CHI2 of the noise about the line); j otherwise."""

    def __init__(self, u):  # (n, 3): the readings over the vector's size
        self.mean = u.mean(axis=0)
        u = u - self.mean  # (a line's slope and scatter do not move with it; the sums keep their digits)
        n = len(u)
        r = np.arange(n, dtype=float)[:, None]
        z = np.zeros((1, 3))
        self.su = np.concatenate([z, np.cumsum(u, axis=0)])
        self.sru = np.concatenate([z, np.cumsum(r * u, axis=0)])
        self.suu = np.concatenate([z, np.cumsum(u * u, axis=0)])

    def end(self, i: int, j: int) -> int:
        # in stretches of TREND_SPAN rows, half overlapping: a line fits a turn of a few degrees, not of a
        # whole turn about the vertical (the accelerometer still, the field's direction going round)
        a = i
        while True:
            b = min(j, a + TREND_SPAN)
            k = self._end(a, b)
            if k < b:
                return k if a == i else a + TREND_SPAN // 4
            if b == j:
                return j
            a += TREND_SPAN // 2

    def _end(self, i: int, j: int) -> int:
        L = j - i
        if L < 3:
            return j
        su = self.su[j] - self.su[i]
        sru = self.sru[j] - self.sru[i] - i * su          # rows counted from i
        suu = self.suu[j] - self.suu[i]
        st, stt = L * (L - 1) / 2.0, (L - 1) * L * (2 * L - 1) / 6.0
        sxx = stt - st * st / L
        slope = (sru - st * su / L) / sxx                  # per row, each component of the direction
        res = np.maximum(suu - su * su / L - slope * slope * sxx, 0.0) / (L - 2)
        # a turn moves the reading across itself; a change of its size along it (a lift's acceleration along
        # gravity, the airbrake IMU's faces) is no turn
        c = su / L + self.mean
        c /= max(float(np.linalg.norm(c)), 1e-300)
        slope = slope - (slope @ c) * c
        turn = float(np.linalg.norm(slope)) * (L - 1)       # radians across the run
        chi2 = float(np.sum(slope * slope * sxx / np.maximum(res, 1e-30)))
        limit = math.radians(HOLD_TURN_DEG)
        if turn <= limit or chi2 <= TREND_CHI2:
            return j
        return i + 1 + int(limit / (turn / (L - 1)))


def find(ds) -> Holds:
    """The static holds of a dataset (module docstring)."""
    n = len(ds)
    w = HOLD_ROWS
    still = np.zeros(n, bool)
    # row i differs from row i - 1 beyond the noise, or a rig axis's setting changes: a hold cannot span them
    jump = setting_changes(ds)
    noise = {}
    ref = None
    dirs = []  # each triad's readings as the holds turn them: a turn about the vertical moves the magnetometer only
    if n >= w:
        quiet = np.ones(n - w + 1, bool)
        for t, unit in (("acc", "g"), ("mag", "nT")):
            if not getattr(ds, f"has_{t}", False):
                continue
            v = np.asarray(getattr(ds, t), float)
            ws = _window_std(v, w)
            s = _noise(ws, ds.meta.get(f"{t}_noise_{unit}"), ds.meta.get(f"{t}_lsb_{unit}"), NOISE_BOUND[t])
            noise[t] = s
            quiet &= np.all(ws <= HOLD_K * s, axis=1)
            jump[1:] |= np.any(np.abs(np.diff(v, axis=0)) > HOLD_JUMP_K * math.sqrt(2.0) * s, axis=1)
            dirs.append((t, _centred(ds, t)))
            if ref is None:
                ref = dirs[-1][1]
        # a row is still when a quiet window covers it
        cover = np.zeros(n + 1, int)
        starts = np.flatnonzero(quiet)
        np.add.at(cover, starts, 1)
        np.add.at(cover, starts + w, -1)
        still = np.cumsum(cover)[:n] > 0
    labels = np.full(n, -1, int)
    count = 0
    if still.any():
        edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
        cos_turn = math.cos(math.radians(HOLD_TURN_DEG))
        u = ref / np.maximum(np.linalg.norm(ref, axis=1, keepdims=True), 1e-300)
        cu = np.concatenate([np.zeros((1, 3)), np.cumsum(u, axis=0)])
        m = (cu[w:] - cu[:-w]) / w  # each window's mean direction
        m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
        # each triad's own steady turn: a turn about the vertical leaves the accelerometer's direction where it was
        # (the readings over the vector's size, not their directions: an offset cancels in a turn's difference, and
        # an accelerometer 0.5 g off reads a hold near the offset turning many times its angle)
        trends = [_Trend(d / _size(ds, t, d)) for t, d in dirs]
        runs = []
        for a, b in zip(edges[::2], edges[1::2]):
            cuts = [a, *(a + 1 + np.flatnonzero(jump[a + 1:b])).tolist(), b]
            runs += list(zip(cuts[:-1], cuts[1:]))
        for a, b in runs:
            i = a
            while b - i >= w:
                anchor = m[i]
                j = _first_turn(m, i, b, anchor, cos_turn)
                if j - i >= w:
                    j = min(t.end(i, j) for t in trends)
                if j - i >= w:
                    labels[i:j] = count
                    count += 1
                    i = j
                else:  # the run starts turning at once: step past its first rows
                    i = max(j, i + 1)
    held = int(np.sum(labels >= 0))
    if declared_static(ds) and count >= 2 and held >= STEP_AND_HOLD_FRACTION * n and held < n:
        # a step-and-hold log declared static: a station read for fewer than HOLD_ROWS rows is a hold too (it
        # was left out as motion), cut where its readings jump or turn like any other
        labels, count = _short_holds(labels, count, jump, ref, math.cos(math.radians(HOLD_TURN_DEG)))
        held = n
    h = Holds(labels=labels, count=count, rows_held=held, rows_moving=n - held, noise=noise)
    return h if declared_static(ds) else _lone_stop_aside(ds, h)


def _lone_stop_aside(ds, h: Holds, moving: bool = False) -> Holds:
    """h, or h with one short hold moved to the rows read while moving: a
    hold of at most LONE_HOLD_MAX_ROWS rows whose leverage alone keeps the
    holds from determining the model, when the others determine it without
    it.  Such a stop is in a direction no other hold has, so one term of the
    ellipsoid would rest on it; a hand or a motor that pauses for a tenth of
    a second while still settling reads one (the MPU-6050 session's rows
    8932-8941: ten rows at 0.1 s, 2.9 deg from the hold that follows 11 rows
    later, leverage 0.87; its 54 other holds alone 0.50).  With it, every
    row of such a log was a pose, and which mode a log was read in hung on
    whether those ten rows passed the stillness test: a scale nonlinearity
    of 0.05 /g on z made them nine, and the holds then determined the
    model.  Not for a run declared static (its every station is one).
    moving: for a log read mostly while moving too (moving_holds), whose
    holds are fewer than half its rows."""
    triads = [t for t in ("acc", "mag") if getattr(ds, f"has_{t}", False)]
    if h.count <= MIN_HOLDS or not (h.step_and_hold or moving) or not triads:
        return h
    ms = {t: means(_centred(ds, t), h.labels, h.count) for t in triads}
    lev = np.max([hold_leverages(m) for m in ms.values()], axis=0)
    j = int(np.argmax(lev))
    rows = np.flatnonzero(h.labels == j)
    if lev[j] <= HOLDS_MAX_LEVERAGE or len(rows) > LONE_HOLD_MAX_ROWS:
        return h
    if max(ellipsoid_leverage(np.delete(m, j, 0)) for m in ms.values()) > HOLDS_MAX_LEVERAGE:
        return h
    labels = h.labels.copy()
    labels[rows] = -1
    labels[labels > j] -= 1
    aside = [{"rows": [int(rows[0]), int(rows[-1])], "leverage": float(lev[j])}]
    return Holds(labels=labels, count=h.count - 1, rows_held=h.rows_held - len(rows),
                 rows_moving=h.rows_moving + len(rows), noise=h.noise, set_aside=aside)


def _centred(ds, t) -> np.ndarray:
    """A triad's readings as the holds turn them: less their mean when it
    lies farther from the origin than the vector they read (a phone's
    magnetometer, ~13 fields off: its raw directions barely turn, and a
    constant added to a hand-turned log's readings had cut its 1 142 holds
    to 864: calib.ellipsoid.far_mean); as read otherwise, and always for the
    accelerometer, whose offsets never come near 1 g: readings held near one
    orientation have their mean there, just beyond 1 g with a scale error
    (an LSM303 on a robot, z up: 1.08 g), and less it they were noise read
    as directions (holds "near +y" on a log whose z never left the
    vertical, and a still log "moving between holds")."""
    from inclino.calib.ellipsoid import far_mean

    v = np.asarray(getattr(ds, t), float)
    if t == "acc":
        return v
    return v - far_mean(v, float(ds.meta.get("field_nT") or 50_000.0))


def declared_static(ds) -> bool:
    """Whether the dataset is declared static (`# static=true`, `[log]
    static = true`, `--static`): every row read at rest."""
    return str(ds.meta.get("static", "")).strip().lower() in ("1", "true", "yes")


def _short_holds(labels, count, jump, ref, cos_turn):
    """labels with each stretch of unlabelled rows made holds of their own:
    a new hold at a jump (or a setting's change) and where the reading's
    direction has turned by more than HOLD_TURN_DEG from the hold's first
    row.  Returns (labels, count)."""
    held = labels >= 0
    labels = labels.copy()
    u = ref / np.maximum(np.linalg.norm(ref, axis=1, keepdims=True), 1e-300)
    start = None
    for i in np.flatnonzero(~held):
        if start is None or held[i - 1] or jump[i] or float(u[i] @ u[start]) < cos_turn:
            start = i
            count += 1
        labels[i] = count - 1
    return labels, count


def ellipsoid_leverage(means) -> float:
    """The largest leverage (hat-matrix diagonal) among k mean readings of a
    triad in the linearised pose-free model (a symmetric 3x3 and an offset:
    |M v + b| = R, to first order a quadric in the reading's direction u and
    its size: u_i u_j (6 columns) and u (3)).  Near 1: that reading alone
    fixes a parameter (a face with no neighbour), so leaving it out is an
    extrapolation; 1.0 when there are fewer readings than parameters."""
    return float(np.max(hold_leverages(means)))


def hold_leverages(means) -> np.ndarray:
    """(k,) each mean reading's leverage in the model of
    ellipsoid_leverage; all 1.0 when the readings do not determine it.  The
    directions are taken from the centre of the best sphere through the
    means where it is far off (_hold_design), else from the origin: an
    offset of a large share of the vector bunches the raw directions (an
    MPU-9250 accelerometer 0.65 g off, stepped through 68 holds over the
    whole sphere, read a leverage of 0.84 from the origin, 0.30 from the
    centre, and its holds were not fitted alone)."""
    v = np.asarray(means, float)
    if len(v) <= 9:
        return np.ones(len(v))
    return _leverages(_hold_design(v)[0])


def _leverages(X) -> np.ndarray:
    """The hat matrix's diagonal of the design X; all 1.0 when X is singular."""
    Q, R = np.linalg.qr(X)
    if np.min(np.abs(np.diag(R))) < 1e-9 * np.max(np.abs(np.diag(R))):
        return np.ones(len(X))
    return np.sum(Q * Q, axis=1)


def _hold_design(means):
    """(design, directions) of the linearised pose-free model over mean
    readings (hold_leverages; ellipsoid.direction_design): the directions
    from the centre of the best sphere through them where one is determined
    and lies more than HOLDS_CENTRE_FRAC of its radius from the origin,
    else from the origin (the leverage limit was set on raw directions: an
    Xsens log 0.1 g off reads 0.78 from the origin, 0.82 from the centre)."""
    from inclino.calib.ellipsoid import direction_design

    return direction_design(means, HOLDS_CENTRE_FRAC)


def undetermined_text(ds, labels, count, t: str, what: str) -> str | None:
    """Why the holds of a triad do not determine its ellipsoid alone, in
    one clause (None when they do): the model's terms that the holds' mean
    directions leave nearly free (ellipsoid.free_terms: the singular
    vectors below HOLDS_FREE_SV of the largest), the hold whose leverage is
    largest, and the orientations that would pin the terms down.  Holds all
    in the x-z and y-z planes leave the x-y cross-axis term free: a phone's
    six-position accelerometer log was refused as "readings on no
    ellipsoid" (its moving rows, fitted with the holds, were)."""
    from inclino.calib.ellipsoid import coverage_hint, free_terms, free_text, terms_text

    v = means(_centred(ds, t), labels, count)
    if len(v) <= 9:
        return (f"the {count} holds found in the readings are too few to determine {what}'s ellipsoid alone "
                f"(9 terms)")
    X, u = _hold_design(v)
    lev = _leverages(X)
    terms, ratio, free = free_terms(X, HOLDS_FREE_SV)
    if float(np.max(lev)) <= HOLDS_MAX_LEVERAGE and ratio >= HOLDS_FREE_SV:
        return None
    j = int(np.argmax(lev))
    d = u[j]
    big = int(np.argmax(np.abs(d)))
    lone = (f"; hold {j + 1}, near {'-' if d[big] < 0 else '+'}{'xyz'[big]}, has leverage {lev[j]:.2f}: it alone "
            f"fixes {'it' if len(terms) <= 1 else 'one combination of them'}" if lev[j] > HOLDS_MAX_LEVERAGE else "")
    # holds all near one axis (a sensor set down on one face, turned about the vertical): said so; the terms
    # they leave free are then every one but that axis's scale and offset
    k = int(np.argmax(np.abs(u).mean(0)))
    off = float(np.degrees(np.arccos(np.clip(np.abs(u[:, k]).min(), 0.0, 1.0))))
    one = f"; every one within {off:.2g} deg of the {'xyz'[k]} axis" if off < ONE_AXIS_DEG else ""
    return (f"the {count} holds found in the readings leave {what}'s {terms_text(terms)[4:]} nearly free ("
            + free_text(free, ratio, HOLDS_FREE_SV) + one + lone + ")"
            + f": add holds with {coverage_hint(terms, u, t == 'acc')}")


def means(v, labels, count) -> np.ndarray:
    """(count, 3): each hold's mean reading."""
    keep = labels >= 0
    out = np.zeros((count, 3))
    np.add.at(out, labels[keep], np.asarray(v, float)[keep])
    return out / np.maximum(np.bincount(labels[keep], minlength=count), 1)[:, None]


# neighbouring holds whose mean directions differ by less than this are one orientation held by a hand that
# drifts (find cuts a run where it turns by HOLD_TURN_DEG): their errors are shared, one orientation
HOLD_MERGE_DEG = 1.0


def merge_neighbours(triads, labels, count) -> tuple:
    """(labels, count) with consecutive holds whose mean readings point
    within HOLD_MERGE_DEG of each other in every triad given (a list of
    (n, 3) arrays) made one: the orientations held, not the stops.  A hand
    that drifts cuts one orientation into several holds (an FXOS8700 session
    turned through 18 orientations read as 71 holds)."""
    same = np.ones(max(count - 1, 0), bool)
    for v in triads:
        m = means(v, labels, count)
        u = m / np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
        same &= np.sum(u[1:] * u[:-1], axis=1) > math.cos(math.radians(HOLD_MERGE_DEG))
    merged = np.concatenate([[0], np.cumsum(~same)])  # hold -> orientation
    return np.where(labels >= 0, merged[np.maximum(labels, 0)], -1), int(merged[-1]) + 1 if count else 0


SETTING_CHANGES_MAX = 0.5      # a partial pose column changing on more rows than this is read, not a setting


def labelled(ds) -> bool:
    """Whether the log says which rows belong together: a pose id, or the
    three pose columns.  A partial pose (a face label, one rig axis's
    setting) does not: it only cuts the holds the readings show (find)."""
    cols = ds.columns
    return any(c in cols for c in ID_COLUMNS) or all(c in cols for c in POSE_COLS)


def setting_changes(ds) -> np.ndarray:
    """(n,) bool: row i's partial pose (the inc_deg, azi_deg or tf_deg
    columns present) differs from row i - 1's: a new setting.  All False
    without one, and for a column that changes on more than
    SETTING_CHANGES_MAX of the rows: a variable read with every row (a rig
    axis logged as it turns), not a setting held."""
    out = setting_starts(ds)
    out[:1] = False
    if len(out) > 1 and np.mean(out[1:]) > SETTING_CHANGES_MAX:
        out[:] = False
    return out


def setting_starts(ds) -> np.ndarray:
    """(n,) bool: the rows at which a setting of the pose columns present
    (inc_deg, azi_deg, tf_deg) starts: the first row, and each row whose
    pose differs from the row before's (all False without a pose column)."""
    n = len(ds)
    present = [c for c in POSE_COLS if c in ds.columns]
    out = np.zeros(n, bool)
    if present and n:
        P = np.stack([np.asarray(ds.columns[c], float) for c in present], -1)
        out[0] = True
        out[1:] = np.any(np.abs(np.diff(P, axis=0)) > 1e-6, axis=1)
    return out


def leverage(ds, h: Holds, triads=("acc", "mag")) -> float:
    """The largest leverage of a hold's mean reading over the present triads
    (ellipsoid_leverage): the holds determine every triad's ellipsoid when
    it is at most HOLDS_MAX_LEVERAGE."""
    return max((ellipsoid_leverage(means(_centred(ds, t), h.labels, h.count))
                for t in triads if getattr(ds, f"has_{t}", False)), default=1.0)


def determining(ds, triads=("acc", "mag")):
    """The holds of a step-and-hold log without poses when they alone
    determine each present triad's ellipsoid (at least 12 holds, leverage at
    most HOLDS_MAX_LEVERAGE): (hold of each row, -1 moving; hold count);
    else None (poses or a pose id given, not step-and-hold, or too few
    directions)."""
    h = _found(ds)
    if h is None or leverage(ds, h, triads) > HOLDS_MAX_LEVERAGE:
        return None
    return h.labels, h.count


def correlated(ds, triads=("acc", "mag")):
    """The holds of a step-and-hold log without poses, whether or not they
    determine the ellipsoids (at least 12): (hold of each row, -1 moving;
    hold count), else None.  When the holds alone leave a triad's model
    undetermined every row is fitted, but the rows of one hold still share
    its orientation's error: the fit's covariance counts each hold once."""
    h = _found(ds)
    return None if h is None else (h.labels, h.count)


def moving_holds(ds, triads=("acc", "mag")):
    """The holds of a log without poses read mostly while moving (not
    step-and-hold: its holds hold fewer than STEP_AND_HOLD_FRACTION of the
    rows), when they alone determine each present triad's ellipsoid (at
    least MIN_HOLDS, leverage at most HOLDS_MAX_LEVERAGE once a lone stop is
    set aside): (hold of each row, -1 moving; hold count); else None.
    Whether the moving rows are to be left out is the caller's to judge (a
    slow turn's rows fit as well as a hold's; a hand's acceleration does
    not: calib.motion)."""
    if labelled(ds) or declared_static(ds):
        return None
    h = find(ds)
    if h.step_and_hold:
        return None
    h = _lone_stop_aside(ds, h, moving=True)
    if h.count < MIN_HOLDS or leverage(ds, h, triads) > HOLDS_MAX_LEVERAGE:
        return None
    return h.labels, h.count


def _found(ds) -> Holds | None:
    """The holds of a step-and-hold log without poses or a pose id, at least
    12 of them; else None."""
    if labelled(ds):
        return None
    h = find(ds)
    return h if h.step_and_hold and h.count >= MIN_HOLDS else None
