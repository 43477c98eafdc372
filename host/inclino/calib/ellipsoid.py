"""Ellipsoid and sphere fits of one triad's readings: the algebraic
starting points every pose-free fit and check begins from (a leaf module:
numpy only)."""
from __future__ import annotations

import itertools

import numpy as np

from inclino.errors import UndeterminedError


# the second-smallest singular value of the (column-scaled) quadric design matrix over its largest: below it
# more than one quadric fits the readings (two circles, a cone, a plane: orientations that do not determine
# an ellipsoid); the smallest carries the noise.  Readings over the sphere give 0.015-0.3, two toolface
# circles at one azimuth 2e-4.
DETERMINED_SV = 2e-3
# the readings' spread (RMS distance from their mean) below this share of their size: one orientation (a static
# log, noise and drift only), whose "sphere" is a ball of noise a few hundred nT across, not the field
SPHERE_MIN_SPREAD = 0.05
SPHERE_MIN_PLANE = 0.003  # the readings' least variance over their largest below this: on a circle, no sphere determined
FAR_MEAN_MIN_SPREAD = 0.1   # far_mean: the readings' RMS distance from their mean over the vector's size, beyond
                            # which they turn (hand-turned phones 13 fields off 0.4 to 1; a QMC5883L 0.19; held
                            # still, or a cap of a few degrees: 0.02 to 0.05)
SPHERE_SHELL = 0.2        # readings' RMS distance from their sphere over its radius: within, the radius is the
                          # field (a VMU931's readings in uT declared mG, 4.8 radii of hard iron off: its median
                          # |b| 17 800 nT looked plausible, its sphere of 3 655 nT was set aside, and the 10x passed)


# the terms of the linearised pose-free model |M (v - b)| = R in a reading's direction u from the centre: u_i^2
# (the scale terms), 2 u_i u_j (the cross-axis terms), u_i (the offsets)
TERMS = ("x scale", "y scale", "z scale", "x-y cross-axis", "x-z cross-axis", "y-z cross-axis", "x offset",
         "y offset", "z offset")
TERM_HINT = {"x-y cross-axis": "x and y both tilted from the vertical (between the x and y axes)",
             "x-z cross-axis": "x and z both tilted (between the x and z axes)",
             "y-z cross-axis": "y and z both tilted (between the y and z axes)",
             "x scale": "the x axis near the vertical", "y scale": "the y axis near the vertical",
             "z scale": "the z axis near the vertical", "x offset": "the x axis up and down",
             "y offset": "the y axis up and down", "z offset": "the z axis up and down"}
FREE_SV = 0.02     # the linearised model's singular values below this share of the largest: nearly free terms
FREE_WEIGHT = 0.4  # a term whose unit vector projects this far into the nearly free subspace is named


def direction_design(v, centre_frac: float = 0.25):
    """(design, directions) of the linearised pose-free model (TERMS) over
    readings v (rows or mean readings): the directions from the centre of
    the best sphere through them where one is determined and lies more than
    centre_frac of its radius from the origin, else from the origin; a
    sphere through readings in a blob (on_shell) has no centre to take them
    from."""
    v = np.asarray(v, float)
    sph = sphere(v)
    if sph is not None and np.linalg.norm(sph[0]) > centre_frac * sph[1] and on_shell(v, sph):
        v = v - sph[0]
    u = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    X = np.column_stack([u[:, 0] ** 2, u[:, 1] ** 2, u[:, 2] ** 2, 2 * u[:, 0] * u[:, 1], 2 * u[:, 0] * u[:, 2],
                         2 * u[:, 1] * u[:, 2], u])
    return X, u


def free_terms(X, free_sv: float) -> tuple[list, float, int]:
    """(terms, ratio, k): the terms of the design X (direction_design) that
    its directions leave nearly free (in the order of TERMS), its least
    singular value over its largest, and how many independent combinations
    of them are nearly free.  The nearly free subspace is spanned by the
    right singular vectors whose singular value is below free_sv of the
    largest (the least one alone when none is: the caller knows the
    readings fail); a term is named when its unit vector projects at least
    FREE_WEIGHT into it, else the terms within 0.7 of the largest
    projection.  Holds all near one axis leave every term but that axis's
    scale and offset free: the least singular vector alone named an
    arbitrary one of them (a Pololu MinIMU-9's holds, all within 6 deg of
    x, were said to leave its y scale and y-z cross-axis terms free)."""
    _, sv, Vt = np.linalg.svd(X, full_matrices=False)
    k = max(1, int(np.sum(sv < free_sv * sv[0])))
    w = np.linalg.norm(Vt[-k:], axis=0)
    named = [i for i in np.argsort(-w) if w[i] >= FREE_WEIGHT] or \
        [i for i in np.argsort(-w) if w[i] >= 0.7 * w.max()]
    return [TERMS[i] for i in (named if len(named) == 1 else sorted(named))], float(sv[-1] / sv[0]), k


def free_text(free: int, ratio: float, free_sv: float) -> str:
    """How nearly free the terms free_terms named are, for a refusal: the
    count of combinations below free_sv of the largest singular value and
    the least ratio, or the least ratio alone when one combination is."""
    if free > 1:
        return (f"{free} combinations of them with singular values below {free_sv:g} of the largest, the least "
                f"{ratio:.2g}")
    return f"the least singular value of their directions {ratio:.2g} of the largest"


def terms_text(terms) -> str:
    """'the z scale term', 'the y scale and y-z cross-axis terms', ..."""
    if len(terms) == 1:
        return f"the {terms[0]} term"
    return "the " + ", ".join(terms[:-1]) + " and " + terms[-1] + " terms"


SEEN_UP = 0.7     # coverage_hint: an axis within 45 deg of the vertical, up (or down), has been read so
SEEN_TILT = 0.35  # ... and a pair of axes each at least 20 deg from the horizontal together, tilted between them


def coverage_hint(terms, u=None, acc: bool = True) -> str:
    """The orientations that pin down the terms: one term's own hint
    (TERM_HINT); for several, the axes to stand near the vertical (up and
    down, for an offset) and the pairs of axes to tilt together.  With the
    directions read (u, (n, 3)) only what they lack is asked for: an axis's
    up or down where no direction comes within 45 deg of it (SEEN_UP), a
    pair no direction tilts between (SEEN_TILT).  An accelerometer's axis
    pointing down reads +1 g (docs/conventions.md); a magnetometer's axis
    along the field reads +F, and its sides are named so (acc False).  An x-io board's 204
    holds, its z axis never above -0.43, leave the z offset and scale
    trading off: "the z axis up", not every axis up and down."""
    if u is None and len(terms) == 1:
        return TERM_HINT[terms[0]]
    u = None if u is None else np.asarray(u, float)
    up, near = [], []
    for a in sorted({t[0] for t in terms if t.endswith("offset") or t.endswith("scale")}):
        k = "xyz".index(a)
        lack_pos = u is None or u[:, k].max() < SEEN_UP
        lack_neg = u is None or u[:, k].min() > -SEEN_UP
        if lack_pos and lack_neg:
            (up if any(t == f"{a} offset" for t in terms) else near).append(a)
        elif lack_pos or lack_neg:
            side = ("down" if lack_pos else "up") if acc else ("along the field" if lack_pos else "against the field")
            up.append(f"{a} {side}")
    pairs = [t.split()[0] for t in terms if "cross-axis" in t
             and (u is None or not np.any(np.all(np.abs(u[:, ["xyz".index(c) for c in t[:3:2]]]) > SEEN_TILT,
                                                 axis=1)))]

    def axes(a):
        return f"the {a[0]} axis" if len(a) == 1 else f"the {', '.join(a[:-1])} and {a[-1]} axes"
    both = [a for a in up if len(a) == 1]
    one = [a for a in up if len(a) > 1]  # one side of an axis only
    parts = ([f"{axes(both)} up and down"] if both else []) + \
        [f"{axes([a[0] for a in one if a[2:] == side])} {side}" for side in dict.fromkeys(a[2:] for a in one)] + \
        ([f"{axes(near)} near the vertical"] if near else [])
    if pairs:
        parts.append(TERM_HINT[f"{pairs[0]} cross-axis"] if len(pairs) == 1 and not parts else
                     "two axes tilted from the vertical together (" + ", ".join(pairs) + ")")
    if not parts:  # every orientation the terms ask for read already: the combination is what is free
        return "orientations between those read"
    return ", and ".join(parts)


def rows_coverage(raw, what: str) -> str | None:
    """Why the readings' own directions leave a term of the ellipsoid nearly
    free, in one clause (None when none is: the linearised model's least
    singular value at least FREE_SV of its largest): the verdict of a fit
    of every row names it beside the inclination it predicts, as it names
    the terms holds leave free (a sensor turned about the vertical at two
    tilts of 20 deg, its z axis never near the vertical, was said only to
    have "coefficients poorly determined")."""
    raw = np.asarray(raw, float)
    if len(raw) < 10:
        return None
    X, u = direction_design(raw)
    terms, ratio, free = free_terms(X, FREE_SV)
    if ratio >= FREE_SV:
        return None
    return (f"the {len(raw)} readings' directions leave {what}'s {terms_text(terms)[4:]} nearly free "
            f"({free_text(free, ratio, FREE_SV)}): add readings with {coverage_hint(terms, u, 'acceler' in what)}")


def _design(raw):
    x, y, z = np.asarray(raw, float).T
    D = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z,
                         np.ones_like(x)])
    s = np.abs(D).max(0)
    s[s == 0] = 1.0
    return D, s


def determined(raw, R=None) -> bool:
    """Whether the readings' orientations determine an ellipsoid (DETERMINED_SV);
    with R, readings farther from the origin than R less their mean (far_mean)."""
    if len(raw) < 10:
        return False
    if R is not None:
        raw = np.asarray(raw, float) - far_mean(raw, R)
    if planar(raw):
        return False
    D, s = _design(raw)
    sv = np.linalg.svd(D / s, compute_uv=False)
    return bool(sv[0] > 0 and sv[-2] / sv[0] >= DETERMINED_SV)


def planar(raw) -> bool:
    """Whether the readings lie on a plane (their least variance over their
    largest below SPHERE_MIN_PLANE): a sensor turned about one axis reads a
    circle, which lies on every sphere and ellipsoid whose axis passes
    through it.  An LSM303 turned once about the vertical on a robot that
    rocked a little (its accelerometer within 0.7 deg of one direction)
    read a circle whose least variance was 0.0019 of its largest; its
    quadric passed the singular-value test (3e-2), and the checks named an
    axis map of the magnetometer from an ellipsoid the noise had picked.
    Turned logs over the sphere: 0.2 to 0.43."""
    raw = np.asarray(raw, float)
    if len(raw) < 4:
        return True
    ev = np.linalg.eigvalsh(np.cov((raw - raw.mean(0)).T))
    return not ev[0] > SPHERE_MIN_PLANE * ev[-1]


def far_mean(raw, R):
    """The readings' mean when it lies farther from the origin than the
    vector they read (R), else 0: a hard-iron offset larger than the field
    (a phone's magnetometer reads ~13 times the field off).  Far from the
    origin the quadric's columns are nearly collinear and its raw
    directions barely turn, so such readings are fitted less this mean
    (the same ellipsoid, in coordinates where its columns are not): fitted
    as logged, a hand-turned log with 13 fields of offset read as "too few
    orientations".  Readings within R of the origin are fitted as logged
    (an accelerometer's offsets never come near 1 g)."""
    raw = np.asarray(raw, float)
    m = raw.mean(0) if len(raw) else np.zeros(3)
    if not (len(raw) > 1 and np.linalg.norm(m) > R):
        return np.zeros(3)
    # readings that do not turn (one orientation, a cap of a few degrees) have their mean where they are, and
    # less it they are noise read as directions: an LSM303 held still at 1.45 fields "moved between 43 holds"
    spread = float(np.sqrt(((raw - m) ** 2).sum(1).mean()))
    return m if spread > FAR_MEAN_MIN_SPREAD * R else np.zeros(3)


MOVED_SIZE = 0.2  # readings whose size (5th to 95th percentile) spreads this share of the vector: moved
ONE_ORIENTATION_DEG = 10.0  # readings all within this of their mean direction are said to be at one orientation


def _as_read(raw, R, shift):
    """The readings a refusal's figures describe: as logged (raw + shift)
    where far_mean's shift is within 2 R of the origin (the mean of an
    accelerometer's readings a hand's acceleration carried past 1 g), else
    less it (a hard-iron offset of many fields: directions from the origin
    would all point along it)."""
    raw = np.asarray(raw, float)
    if shift is None or np.linalg.norm(shift) > 2.0 * R:
        return raw
    return raw + shift


def ellipsoid_start(raw, R, what: str = "the triad", _shift=None):
    """Algebraic general ellipsoid fit: (M symmetric, b) with |M (raw - b)| ~ R.
    UndeterminedError (exit 3) naming `what` when the readings determine no ellipsoid.
    Readings whose mean is farther from the origin than R are fitted less
    that mean (far_mean), b given back in the readings' coordinates."""
    raw = np.asarray(raw, float)
    m = far_mean(raw, R)
    if np.any(m):
        M, b = ellipsoid_start(raw - m, R, what, _shift=m)
        return M, b + m
    D, s = _design(raw)
    _, sv, Vt = np.linalg.svd(D / s, full_matrices=False)
    if len(raw) < 10 or planar(raw) or not sv[-2] / sv[0] >= DETERMINED_SV:
        mean = raw.mean(0) if len(raw) else np.zeros(3)
        cap = float(np.degrees(np.arcsin(min(1.0, np.sqrt(((raw - mean) ** 2).sum(1).max()) / np.linalg.norm(mean)))))\
            if len(raw) and np.linalg.norm(mean) > 0 else None
        if cap is not None and cap < ONE_ORIENTATION_DEG:
            raise UndeterminedError(f"too few orientations to determine {what}'s ellipsoid (every reading within "
                                    f"{cap:.2g} deg of one direction: the sensor at one orientation, or turned only "
                                    f"about the vector it reads: turn the sensor through more of the sphere)")
        # which terms the readings leave free, in the linearised model the holds are judged by: "a few circles"
        # alone left the user to guess which orientations were missing
        if len(raw) < 10:
            raise UndeterminedError(f"too few readings to determine {what}'s ellipsoid ({len(raw)}, fewer than its "
                                    f"10 coefficients)")
        X, u = direction_design(_as_read(raw, R, _shift))
        terms, _, _ = free_terms(X, FREE_SV)
        raise UndeterminedError(f"too few orientations to determine {what}'s ellipsoid (readings on a few circles "
                                f"or in a plane, which leave its {terms_text(terms)[4:]} free: turn the sensor "
                                f"through more of the sphere, with {coverage_hint(terms, u, 'acceler' in what)})")
    v = Vt[-1] / s
    Q = np.array([[v[0], v[3], v[4]], [v[3], v[1], v[5]], [v[4], v[5], v[2]]])
    if np.linalg.eigvalsh(Q).min() * np.linalg.eigvalsh(Q).max() <= 0:
        why = ("the readings of a moving sensor, whose acceleration is no sensor effect" if "acceler" in what else
               "a field that changed while they were read (steel or a current near the sensor)")
        # the cap named by the terms its directions leave free, where they leave any
        read = _as_read(raw, R, _shift)
        X, u = direction_design(read)
        terms, ratio, _ = free_terms(X, FREE_SV)
        # both causes with the figures that decide between them: how far the directions lean to one side (an
        # x-io NGIMU held at one orientation and moved between: 0.97) and how much the readings' size changes
        lean = float(np.linalg.norm(u.mean(0)))
        cap = (f"too few orientations: a cap of the sphere, as a sensor that hardly tilts reads (the directions' "
               f"mean resultant {lean:.2f}: 0 for every direction, 1 for one)" if ratio >= FREE_SV
               else f"too few orientations, which leave its {terms_text(terms)[4:]} nearly free: add readings with "
                    f"{coverage_hint(terms, u, 'acceler' in what)}")
        size = np.percentile(np.linalg.norm(read, axis=1), [5, 95]) / R
        why += (f" (their size from {size[0]:.2f} to {size[1]:.2f} of {R:.4g} {'g' if 'acceler' in what else 'nT'}, "
                f"5th to 95th percentile)")
        # the size changing by more than MOVED_SIZE of the vector is the likelier cause, named first
        first, second = (why, cap) if size[1] - size[0] > MOVED_SIZE else (cap, why)
        raise UndeterminedError(f"{what}'s readings do not lie on an ellipsoid ({first}; or {second}): log it at "
                                f"rest, or turned slowly, through more of the sphere")
    if np.trace(Q) < 0:
        Q, v = -Q, -v
    c = -np.linalg.solve(Q, v[6:9])
    k = c @ Q @ c - v[9]
    if k <= 0:
        raise UndeterminedError(f"{what}: degenerate ellipsoid fit (too few orientations, or a moving sensor)")
    w, U = np.linalg.eigh(Q / k)
    M = U @ np.diag(np.sqrt(w)) @ U.T * R
    return M, c


def sphere(v):
    """Centre and radius of the best sphere through the readings (linear
    least squares |v|^2 = 2 v.c + k), or None when they do not span 3-D
    (directions from the centre in a plane, or the readings at one
    orientation: SPHERE_MIN_SPREAD)."""
    v = np.asarray(v, float)
    if len(v) < 10:
        return None
    mean = v.mean(0)
    spread = float(np.sqrt(((v - mean) ** 2).sum(1).mean()))
    if not spread > SPHERE_MIN_SPREAD * float(np.linalg.norm(mean)):
        return None
    if planar(v):
        # the readings on a circle (a sensor turned about one axis: a compass turned on a table): a circle lies
        # on every sphere whose centre is on its axis, and the fit's radius is whichever the noise picks (a
        # horizontal circle of 20 uT read as a sphere of 20 uT where |b| is 71 uT)
        return None
    A = np.column_stack([2 * v, np.ones(len(v))])
    y = (v * v).sum(1)
    scale = np.abs(A).max(0)
    scale[scale == 0] = 1.0
    sol, *_ = np.linalg.lstsq(A / scale, y, rcond=None)
    sol = sol / scale
    c, k = sol[:3], sol[3]
    r2 = k + c @ c
    if not np.isfinite(r2) or r2 <= 0:
        return None
    u = v - c
    u = u / np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    if np.linalg.eigvalsh(u.T @ u / len(u)).min() < 0.02:  # directions in a plane: the centre is not determined
        return None
    return c, float(np.sqrt(r2))


def signed_permutations(proper: bool = False) -> list:
    """The 48 axis maps that permute and sign-flip three axes (3x3, one +-1
    per row and column); with proper=True the 24 of them that are rotations
    (determinant +1)."""
    out = []
    for p in itertools.permutations(range(3)):
        for s in itertools.product((1, -1), repeat=3):
            m = np.zeros((3, 3))
            for i in range(3):
                m[i, p[i]] = s[i]
            if not proper or np.linalg.det(m) > 0:
                out.append(m)
    return out


def on_shell(v, sph) -> bool:
    """Whether the readings lie on the sphere sph = (centre, radius) as on a
    shell (their RMS distance from it within SPHERE_SHELL of its radius),
    not in a blob that a sphere merely passes through.  A shell's radius is
    the field whatever the hard-iron offset; a blob's is its own size.
    Measured: 17 real magnetometer logs turned by hand or on a rig 0.007 to
    0.16 of the radius; readings of a sensor that hardly turned (a noise
    blob, a phone in a car's cup holder, a foot on steel stairs) 0.27 to
    0.40."""
    c, R = sph[0], sph[1]
    r = np.linalg.norm(np.asarray(v, float) - c, axis=1)
    return bool(np.sqrt(np.mean((r - R) ** 2)) <= SPHERE_SHELL * R)
