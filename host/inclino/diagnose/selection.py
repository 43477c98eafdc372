"""Best-subset model selection with nested cross-validation: which
candidate effects the data ask for, how well the chosen model generalises,
and which rival models explain the data as well.

One implementation for every analysis that chooses terms of a weighted
linear model y = X b + e (the papers' attitude errors, `papers.py`; the
raw-data diagnosis's rival report, `analysis.py`):

* **Search.**  Every subset of the candidate pool up to `max_terms` terms
  (8 by default) is scored by its leave-one-out (LOO) residuals, computed in
  closed form (r / (1 - h)) for all subsets of one size at once; the chosen
  model is the one with the smallest weighted LOO mean square.  Exhaustive,
  so no greedy path dependence: a term taken first is not kept because it
  was first.
* **Rivals.**  Every model whose LOO mean square is within one standard
  error (of the paired difference of squared LOO errors against the
  chosen model) of the chosen one's.
* **Nested CV.**  The whole procedure (search included) is cross-validated:
  for each held-out number (nested LOO) or each held-out group (for grid
  data, e.g. every number at one inclination: nested leave-one-group-out),
  the search runs on the rest and the model it chooses predicts what was
  held out.  That is the honest figure for a model chosen from the data.
* **Drop from the pool.**  For each term of the chosen model: the nested
  LOO of the procedure with that term removed from the pool.  The term is
  "asked for by the data" only if that worsens the nested LOO mean square
  by more than one standard error (paired over the numbers); otherwise the
  report names the model chosen without it (its rivals).

Errors are reported in y's units; weights w (1/sigma per number) put numbers
of different kinds on one noise scale, the mean squares are of w x error."""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

MAX_TERMS = 8
# values of the (subsets, rows, columns) design a subset search gathers at a time (32 MB)
SEARCH_BATCH_VALUES = 1 << 22
COND_MAX = 1e10  # a subset whose (column-normalised) normal matrix is worse than this is not identifiable


@dataclass
class Problem:
    """Terms are what is selected: a term is one column, or several that
    enter together (e.g. an offset along body x and y when the toolface
    that would tell them apart is unknown)."""
    X: np.ndarray  # (n, p) candidate columns
    y: np.ndarray  # (n,)
    w: np.ndarray  # (n,) weights (1/sigma)
    names: list  # one name per term
    groups: np.ndarray | None = None  # (n,) group label for leave-one-group-out
    terms: list | None = None  # per term the tuple of its columns; default one column each
    colnames: list | None = None  # per column (default: the term's name, with /k for multi-column terms)

    def __post_init__(self):
        if self.terms is None:
            self.terms = [(j,) for j in range(self.X.shape[1])]
        if self.colnames is None:
            self.colnames = [None] * self.X.shape[1]
            for name, t in zip(self.names, self.terms):
                for q, c in enumerate(t):
                    self.colnames[c] = name if len(t) == 1 else f"{name}/{q}"

    def subset(self, rows):
        return Problem(self.X[rows], self.y[rows], self.w[rows], self.names,
                       None if self.groups is None else self.groups[rows], self.terms, self.colnames)

    def columns(self, S) -> list:
        return [c for t in S for c in self.terms[t]]


def _subset_gram(Xw, subsets):
    """For every subset (m, k) of the columns of Xw: the columns scaled to
    unit norm A (m, n, k), the inverse of their Gram matrix Gi (m, k, k), and
    `bad` (m,) where a column is zero or the Gram matrix's condition exceeds
    COND_MAX (its Gi is then the identity, and callers score it as inf)."""
    k = subsets.shape[1]
    A = np.transpose(Xw[:, subsets], (1, 0, 2))  # (m, n, k)
    norm = np.sqrt((A ** 2).sum(1))  # (m, k)
    bad = np.any(norm == 0, 1)
    A = A / np.where(norm == 0, 1.0, norm)[:, None, :]
    G = np.einsum("mnk,mnj->mkj", A, A, optimize=True)
    ev = np.linalg.eigvalsh(G)
    bad |= ev[:, 0] <= ev[:, -1] / COND_MAX
    G[bad] = np.eye(k)
    return A, np.linalg.inv(G), bad


def _loo_batch(Xw, yw, subsets):
    """Weighted LOO residuals (m, n) of every subset (m, k) of the columns."""
    n = len(yw)
    m, k = subsets.shape
    if k == 0:
        return np.broadcast_to(yw, (m, n)).copy(), np.zeros(m, bool)
    A, Gi, bad = _subset_gram(Xw, subsets)
    b = np.einsum("mij,mnj,n->mi", Gi, A, yw, optimize=True)
    r = yw[None, :] - np.einsum("mnk,mk->mn", A, b, optimize=True)
    B = np.einsum("mnk,mkj->mnj", A, Gi, optimize=True)  # (numpy's batched matmul is slow for small k)
    h = (B * A).sum(-1)
    loo = r / np.maximum(1.0 - h, 1e-9)
    loo[bad] = np.inf
    return loo, bad


def _inner_press_batch(Xw, yw, subsets):
    """For every subset (m, k) and every held-out number i: the sum of
    squared weighted LOO residuals of the model fitted without i (the inner
    search's score in a nested LOO), by the leave-two-out formula
    e_j = (h_ij r_i + (1 - h_ii) r_j) / ((1 - h_ii)(1 - h_jj) - h_ij^2).
    Returns (press (m, n), loo (m, n))."""
    n = len(yw)
    m, k = subsets.shape
    if k == 0:
        loo = np.broadcast_to(yw, (m, n)).copy()
        return (yw ** 2).sum() - loo ** 2, loo
    A, Gi, bad = _subset_gram(Xw, subsets)
    B = np.einsum("mnk,mkj->mnj", A, Gi, optimize=True)
    H = np.einsum("mik,mjk->mij", B, A, optimize=True)  # (m, n, n)
    b = np.einsum("mij,mnj,n->mi", Gi, A, yw, optimize=True)
    r = yw[None, :] - np.einsum("mnk,mk->mn", A, b, optimize=True)
    h = np.diagonal(H, axis1=1, axis2=2)
    om = 1.0 - h  # (m, n)
    det = om[:, :, None] * om[:, None, :] - H ** 2  # [m, i, j]
    e = (H * r[:, :, None] + om[:, :, None] * r[:, None, :]) / np.where(np.abs(det) < 1e-12, 1e-12, det)
    idx = np.arange(n)
    e[:, idx, idx] = 0.0
    press = (e ** 2).sum(2)
    loo = r / np.maximum(om, 1e-9)
    press[bad] = np.inf
    loo[bad] = np.inf
    return press, loo


def all_subsets(pb: Problem, pool: list, max_terms: int = MAX_TERMS, inner: bool = False):
    """(subsets, weighted LOO residuals (m, n)[, inner PRESS (m, n)]) of
    every subset of the terms `pool` up to max_terms terms, unsorted."""
    Xw = pb.X * pb.w[:, None]
    yw = pb.y * pb.w
    n = len(yw)
    by_cols = {}
    for k in range(min(max_terms, len(pool)) + 1):
        for c in itertools.combinations(pool, k):
            cols = pb.columns(c)
            if len(cols) <= n - 3:
                by_cols.setdefault(len(cols), []).append((tuple(c), cols))
    subs, errs, press = [], [], []
    for k, items in sorted(by_cols.items()):
        combos = np.array([cols for _, cols in items], int).reshape(len(items), k)
        for lo in range(0, len(items), 256):  # bounded memory: (256, n, n)
            part = combos[lo:lo + 256]
            if inner:
                p, loo = _inner_press_batch(Xw, yw, part)
                press.append(p)
            else:
                loo, _ = _loo_batch(Xw, yw, part)
            errs.append(loo)
        subs += [S for S, _ in items]
    E = np.concatenate(errs, 0)
    return (subs, E, np.concatenate(press, 0)) if inner else (subs, E)


def nested_loo_all(pb: Problem, pool: list, max_terms: int = MAX_TERMS):
    """A function restricted_pool -> (nested LOO residuals (n,) in y units,
    the model chosen for each held-out number): the subsets' scores are
    computed once, a pool restriction only masks them."""
    subs, E, P = all_subsets(pb, pool, max_terms, inner=True)
    sets = [set(S) for S in subs]

    def run(pool2):
        allowed = np.array([S <= set(pool2) for S in sets])
        Pm = np.where(allowed[:, None], P, np.inf)
        best = np.argmin(Pm, 0)  # per held-out number
        n = len(pb.y)
        res = E[best, np.arange(n)] / pb.w
        return res, [subs[b] for b in best]
    return run


def _group_batch(Xw, yw, subsets, groups):
    """Weighted leave-one-group-out residuals (m, n) of every subset."""
    n = len(yw)
    m, k = subsets.shape
    if k == 0:
        return np.broadcast_to(yw, (m, n)).copy()
    A = np.transpose(Xw[:, subsets], (1, 0, 2))  # (m, n, k)
    out = np.zeros((m, n))
    for g in np.unique(groups):
        te = groups == g
        At = A[:, ~te]
        G = np.einsum("mnk,mnj->mkj", At, At, optimize=True)
        ev = np.linalg.eigvalsh(G)
        bad = ev[:, 0] <= np.maximum(ev[:, -1], 1e-300) / COND_MAX
        G[bad] = np.eye(k)
        b = np.linalg.solve(G, np.einsum("mnk,n->mk", At, yw[~te], optimize=True)[..., None])[..., 0]
        out[:, te] = yw[te][None, :] - np.einsum("mnk,mk->mn", A[:, te], b, optimize=True)
        out[bad] = np.inf
    return out


def search(pb: Problem, pool: list, max_terms: int = MAX_TERMS, forced: tuple = (), cv: str = "loo",
           errors: bool = True):
    """All subsets of the terms `pool` up to max_terms terms, plus the
    `forced` terms in every model.  Returns (subsets as tuples of terms,
    best first; their weighted held-out residuals E (m, n): leave-one-out,
    or leave-one-group-out with cv='group'; order), E's row order[j] being
    the j-th subset's (E is not sorted: a sorted copy doubled the largest
    array of the search); errors False: E is None, the residuals not kept
    (the nested runs need only the order: each (m, n) array of a
    40 000-row run's residuals is over 100 MB)."""
    Xw = pb.X * pb.w[:, None]
    yw = pb.y * pb.w
    n = len(yw)
    kmax = min(max_terms, len(pool))
    by_cols = {}
    for k in range(kmax + 1):
        for c in itertools.combinations(pool, k):
            S = tuple(forced) + tuple(c)
            cols = pb.columns(S)
            if len(cols) <= n - 2:
                by_cols.setdefault(len(cols), []).append((S, cols))
    m = sum(len(items) for items in by_cols.values())
    E = np.empty((m, n)) if errors else None
    subs, score = [], np.empty(m)
    for k, items in sorted(by_cols.items()):
        combos = np.array([cols for _, cols in items], int).reshape(len(items), k)
        # the subsets a batch at a time: each batch gathers a (subsets, n, k) design (and its training
        # rows again per group); all of them at once held over 200 MB on a 40 000-row run's residuals
        step = max(1, SEARCH_BATCH_VALUES // max(n * k, 1))
        for lo in range(0, len(combos), step):
            part = combos[lo:lo + step]
            e = _group_batch(Xw, yw, part, pb.groups) if cv == "group" else _loo_batch(Xw, yw, part)[0]
            at = len(subs) + lo
            with np.errstate(invalid="ignore", over="ignore"):
                score[at:at + len(part)] = np.mean(e ** 2, 1)
            if errors:
                E[at:at + len(part)] = e
        subs += [S for S, _ in items]
    order = np.argsort(score, kind="stable")
    return [subs[i] for i in order], E, order


def fit(pb: Problem, S):
    """(beta, covariance, residuals) of the model S, weighted least squares,
    s^2 from the weighted residuals."""
    S = pb.columns(S)
    n = len(pb.y)
    if not S:
        return np.zeros(0), np.zeros((0, 0)), pb.y.copy()
    A = pb.X[:, S] * pb.w[:, None]
    beta, *_ = np.linalg.lstsq(A, pb.y * pb.w, rcond=None)
    r = pb.y - pb.X[:, S] @ beta
    s2 = float(((r * pb.w) ** 2).sum()) / max(n - len(S), 1)
    return beta, s2 * np.linalg.pinv(A.T @ A), r


def group_cv(pb: Problem, S):
    """Leave-one-group-out residuals (n,) of the fixed model S (y units)."""
    out = np.zeros(len(pb.y))
    for g in np.unique(pb.groups):
        m = pb.groups == g
        beta, _, _ = fit(pb.subset(~m), S)
        out[m] = pb.y[m] - (pb.X[m][:, pb.columns(S)] @ beta if len(S) else 0.0)
    return out


def loo_cv(pb: Problem, S):
    """Leave-one-out residuals (n,) of the fixed model S (y units)."""
    loo, _ = _loo_batch(pb.X * pb.w[:, None], pb.y * pb.w, np.array([pb.columns(S)], int).reshape(1, -1))
    return loo[0] / pb.w


def nested(pb: Problem, pool, max_terms=MAX_TERMS, by="one", forced=(), cv="loo"):
    """Nested CV residuals (n,) in y units of the procedure 'choose by
    best-subset LOO, then fit': held out one number at a time (by='one') or
    one group at a time (by='group'); also the model chosen each time."""
    out = np.zeros(len(pb.y))
    chosen = []
    keys = range(len(pb.y)) if by == "one" else np.unique(pb.groups)
    for key in keys:
        m = np.zeros(len(pb.y), bool)
        if by == "one":
            m[key] = True
        else:
            m = pb.groups == key
        train = pb.subset(~m)
        subs = search(train, pool, max_terms, forced, cv, errors=False)[0]
        S = subs[0]
        beta, _, _ = fit(train, S)
        out[m] = pb.y[m] - (pb.X[m][:, pb.columns(S)] @ beta if len(S) else 0.0)
        chosen.append(S)
    return out, chosen


def estimates(pb: Problem, S, beta, cov, units=None) -> list:
    """Per term of S: its value and stderr (one column) or its components
    and their norm (several)."""
    units = units or {}
    out, q = [], 0
    for t in S:
        cols = pb.terms[t]
        comp = {pb.colnames[c]: {"value": float(beta[q + i]), "stderr": float(np.sqrt(cov[q + i, q + i]))}
                for i, c in enumerate(cols)}
        e = {"term": pb.names[t], "units": units.get(pb.names[t], "")}
        if len(cols) == 1:
            e.update(next(iter(comp.values())))
        else:
            e["components"] = comp
            e["magnitude"] = float(np.linalg.norm(beta[q:q + len(cols)]))
        out.append(e)
        q += len(cols)
    return out


def rms(v):
    v = np.asarray(v, float)
    return float(np.sqrt(np.mean(v ** 2))) if len(v) else float("nan")


def _paired_se(a, b):
    d = a - b
    if len(d) < 2 or not np.all(np.isfinite(d)):
        return float("inf")
    return float(np.std(d, ddof=1) / np.sqrt(len(d)))


@dataclass
class Selection:
    """What `select` found (JSON-ready via to_dict)."""
    pool: list
    chosen: list
    estimates: list
    loo_rms: float
    group_rms: float | None
    nested_loo_rms: float
    nested_group_rms: float | None
    rivals: list = field(default_factory=list)
    drop_tests: list = field(default_factory=list)
    nested_models: dict = field(default_factory=dict)
    weights: dict = field(default_factory=dict)
    nested_residuals: np.ndarray | None = field(default=None, repr=False)  # not in to_dict

    def to_dict(self):
        return {k: getattr(self, k) for k in ("pool", "chosen", "estimates", "loo_rms", "group_rms",
                                              "nested_loo_rms", "nested_group_rms", "rivals", "drop_tests",
                                              "nested_models", "weights")}


def select(pb: Problem, pool=None, max_terms=MAX_TERMS, drop_tests=True, units=None, max_rivals=12,
           cv: str = "loo") -> Selection:
    """Best-subset selection with rivals, nested CV and the drop-from-pool
    test (see the module docstring).  units: name -> unit string.
    cv='group': every score is leave-one-group-out instead of leave-one-out
    (large data sets: the groups are the cross-validation folds); the
    nested_loo_rms fields then hold the nested leave-one-group-out."""
    pool = list(range(len(pb.terms))) if pool is None else list(pool)
    units = units or {}
    subs, E, order = search(pb, pool, max_terms, cv=cv)
    S = subs[0]
    beta, cov, r = fit(pb, S)
    se_best = E[order[0]] ** 2
    rivals = []
    for j in range(1, len(subs)):
        if len(rivals) >= max_rivals:
            break
        e = E[order[j]]
        if not np.all(np.isfinite(e)):
            break  # the rest are not identifiable (sorted last)
        diff = float(np.mean(e ** 2) - np.mean(se_best))
        se = _paired_se(e ** 2, se_best)
        if diff <= se:
            b, c, _ = fit(pb, subs[j])
            rivals.append({"terms": [pb.names[i] for i in subs[j]],
                           "estimates": estimates(pb, subs[j], b, c, units),
                           "loo_rms": rms(loo_cv(pb, subs[j])) if cv == "loo" else None,
                           "group_rms": rms(group_cv(pb, subs[j])) if pb.groups is not None else None,
                           "loo_ms_minus_chosen": diff, "one_se": se})
    E = e = se_best = None  # (m, n): not used again, not held through the nested runs
    if cv == "group":
        def nested_run(p):
            return nested(pb, p, max_terms, "group", cv="group")
    else:
        nested_run = nested_loo_all(pb, pool, max_terms)
    nl, chosen_l = nested_run(pool)
    if cv == "group":
        ng = nl
    else:
        ng, _ = nested(pb, pool, max_terms, "group") if pb.groups is not None else (None, None)
    freq = {}
    for Sx in chosen_l:
        key = " + ".join(pb.names[i] for i in Sx) or "(none)"
        freq[key] = freq.get(key, 0) + 1
    out = Selection(
        pool=[pb.names[i] for i in pool], chosen=[pb.names[i] for i in S],
        estimates=estimates(pb, S, beta, cov, units),
        loo_rms=rms(loo_cv(pb, S)) if cv == "loo" else None, group_rms=rms(group_cv(pb, S)) if pb.groups is not None else None,
        nested_loo_rms=rms(nl), nested_group_rms=rms(ng) if ng is not None else None, rivals=rivals,
        nested_models={"leave_one_out": dict(sorted(freq.items(), key=lambda t: -t[1]))}, nested_residuals=nl)
    if drop_tests:
        base_sq = (nl * pb.w) ** 2
        for i in S:
            p2 = [j for j in pool if j != i]
            nl2, _ = nested_run(p2)
            sq = (nl2 * pb.w) ** 2
            diff = float(np.mean(sq) - np.mean(base_sq))
            se = _paired_se(sq, base_sq)
            subs2 = search(pb, p2, max_terms, cv=cv, errors=False)[0]
            alt = subs2[0]
            out.drop_tests.append({
                "term": pb.names[i], "nested_loo_rms_without": rms(nl2), "nested_loo_rms_with": rms(nl),
                "ms_increase": diff, "one_se": se, "asked_for_by_the_data": bool(diff > se),
                "model_without_it": [pb.names[j] for j in alt],
                "model_without_it_loo_rms": rms(loo_cv(pb, alt)) if cv == "loo" else None,
                "model_without_it_group_rms": rms(group_cv(pb, alt)) if pb.groups is not None else None})
    return out
