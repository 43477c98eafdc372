"""Term selection on the papers' attitude errors: the shared best-subset
selection (`selection.py`) with the unknown toolface handled.

Terms.  Every library turntable effect (world-fixed: its attitude error does
not depend on the probe's toolface, which the papers do not give) is one
term.  The sensor-level alternatives (fluxgate offset, fluxgate rotated
against the accelerometer, accelerometer offset) are computed at an assumed
toolface; each is offered as its body-z component alone (the tool axis:
the same at every toolface) and as its x and y components together (a pair:
a toolface changes only the direction of the pair in the x-y plane, never
what the pair can fit), and, to show why not, as x or y alone.

Toolface scan.  Each sensor-level term is fitted together with the best
turntable-only model at every assumed toolface 0, 30, ..., 330 deg: its
estimate (a pair: its magnitude) over the scan is reported as a range.  A
single-column term whose sign changes over the scan, or whose size changes
by more than 2x (a pair's magnitude by more than 1.5x), rests on the
unknown and is dropped from the pool.

Weights.  Inclination and azimuth errors are put on one noise scale by
weighting each kind with 1 / its residual RMS under the best model of the
full pool (one refinement from the no-model residuals).

Acceptance.  The chosen model is reported as what the data ask for only if
its nested leave-one-out mean square beats the no-error model's by more
than one standard error (paired over the numbers); otherwise no effect is
kept and the best model is listed as not accepted."""
from __future__ import annotations

import copy

import numpy as np

from . import selection as sel

TOOLFACES = np.arange(0.0, 360.0, 30.0)
SINGLE_RATIO_MAX = 2.0
PAIR_RATIO_MAX = 1.5


def _kind_weights(kind, r):
    w = np.ones(len(r))
    for k in ("inc", "azi"):
        m = kind == k
        if m.any():
            w[m] = 1.0 / max(float(np.sqrt(np.mean(r[m] ** 2))), 1e-6)
    return w


def build_terms(cands):
    """[(label, name, axis, units, [candidates])]: turntable terms, and per
    sensor-level kind z alone, x alone, y alone, (x, y) together."""
    out = []
    for c in cands:
        if c.kind == "turntable":
            out.append((f"{c.name} ({c.axis})", c.name, c.axis, c.units, [c]))
    kinds = []
    for c in cands:
        if c.kind != "turntable" and c.kind not in kinds:
            kinds.append(c.kind)
    for k in kinds:
        cs = {c.axis: c for c in cands if c.kind == k}
        for ax in ("z", "x", "y"):
            if ax in cs:
                c = cs[ax]
                out.append((f"{c.name} ({ax})", c.name, ax, c.units, [c]))
        if "x" in cs and "y" in cs:
            c = cs["x"]
            out.append((f"{c.name} (x, y)", c.name, "x, y", c.units, [cs["x"], cs["y"]]))
    return out


def _problem(chk, y, terms, cols, w, groups):
    X, tcols = [], []
    colnames = []
    for label, name, axis, units, cs in terms:
        idx = []
        for c in cs:
            idx.append(len(X))
            X.append(cols[c])
            colnames.append(f"{c.name} ({c.axis})")
        tcols.append(tuple(idx))
    return sel.Problem(np.column_stack(X), y, w, [t[0] for t in terms], groups, tcols, colnames)


def toolface_scan(chk, y, terms, colfn, w, base_terms):
    """Per sensor-level term: its estimate over the assumed toolfaces (with
    the turntable model base_terms), range and stability."""
    scans = {}
    for T in TOOLFACES:
        ck = copy.copy(chk)
        ck.T = np.full(len(chk.I), float(T))
        cols = {}
        for t in terms:
            for c in t[4]:
                if c not in cols:
                    cols[c] = colfn(ck, c)
        for j, t in enumerate(terms):
            if t[4][0].kind == "turntable":
                continue
            model = [terms[i] for i in base_terms] + [t]
            pb = _problem(ck, y, model, cols, w, None)
            beta, _, _ = sel.fit(pb, list(range(len(model))))
            v = beta[-len(t[4]):]
            scans.setdefault(j, []).append(float(v[0]) if len(v) == 1 else float(np.linalg.norm(v)))
    out = {}
    for j, vals in scans.items():
        v = np.array(vals)
        a = np.abs(v)
        pair = len(terms[j][4]) > 1
        ratio = float(a.max() / max(a.min(), 1e-300))
        if pair:
            stable = ratio <= PAIR_RATIO_MAX
            why = None if stable else f"its magnitude changes {ratio:.2g}x over the toolface"
        else:
            same_sign = bool(np.all(v > 0) or np.all(v < 0))
            stable = same_sign and ratio <= SINGLE_RATIO_MAX
            why = None if stable else ("its sign changes over the toolface" if not same_sign else
                                       f"its size changes {ratio:.2g}x over the toolface")
        out[j] = {"term": terms[j][0], "units": terms[j][3], "quantity": "magnitude" if pair else "value",
                  "min": float(v.min()), "max": float(v.max()), "stable": bool(stable), "why_dropped": why,
                  "toolfaces_deg": TOOLFACES.tolist()}
    return out


def select_terms(chk, y, cands, colfn, max_terms=sel.MAX_TERMS, groups=None, scan=True, drop_tests=True,
                 pool_filter=None) -> dict:
    """The selection on the checks' residual y (measured - predicted).
    colfn(chk, cand) -> column at chk's toolface.  pool_filter(term) ->
    bool restricts the pool (for the comparisons).  Returns a JSON-ready
    dict (see the module docstring)."""
    terms = build_terms(cands)
    if pool_filter is not None:
        terms = [t for t in terms if pool_filter(t)]
    cols = {}
    for t in terms:
        for c in t[4]:
            cols[c] = colfn(chk, c)
    n = len(y)
    max_terms = min(max_terms, max(n // 3, 1))
    # the pool: turntable terms, sensor terms without the x/y singles unless not scanning
    scan_out = {}
    w = _kind_weights(chk.kind, y)
    tt = [j for j, t in enumerate(terms) if t[4][0].kind == "turntable"]
    if scan and len(tt) < len(terms):
        pb0 = _problem(chk, y, terms, cols, w, None)
        base = sel.search(pb0, tt, max_terms, errors=False)[0][0] if tt else ()
        scan_out = toolface_scan(chk, y, terms, colfn, w, list(base))
        pool = [j for j in range(len(terms)) if j in tt or scan_out[j]["stable"]]
    else:
        # no scan: every single-column term (the assumed toolface taken as known)
        pool = [j for j, t in enumerate(terms) if len(t[4]) == 1]
    pb = _problem(chk, y, terms, cols, w, groups)
    if pool:
        subs = sel.search(pb, pool, max_terms, errors=False)[0]
        _, _, r = sel.fit(pb, subs[0])
        w = _kind_weights(chk.kind, r)
        pb = _problem(chk, y, terms, cols, w, groups)
    units = {t[0]: t[3] for t in terms}
    s = sel.select(pb, pool, max_terms, drop_tests=drop_tests, units=units)
    chosen_idx = [pb.names.index(nm) for nm in s.chosen]
    beta, _, r = sel.fit(pb, chosen_idx)
    # acceptance: nested LOO against the no-error model, paired, in weighted squares
    nl = s.nested_residuals
    a, b = (nl * w) ** 2, (y * w) ** 2
    gain = float(np.mean(b) - np.mean(a))
    se = float(np.std(b - a, ddof=1) / np.sqrt(n)) if n > 1 else float("inf")
    accepted = bool(s.chosen) and gain > se
    fitted = (y - r) if accepted else np.zeros(n)
    resid = y - fitted
    out = {"n": n, "rms_before": sel.rms(y), "loo_rms_before": sel.rms(y),
           "rms_after": sel.rms(resid), "loo_rms_after": s.loo_rms if accepted else sel.rms(y),
           "nested_loo_rms": s.nested_loo_rms, "group_rms": s.group_rms, "nested_group_rms": s.nested_group_rms,
           "accepted": accepted, "nested_gain_ms": gain, "nested_gain_one_se": se,
           "selection": s.to_dict(), "toolface_scan": list(scan_out.values()),
           "pool": [terms[j][0] for j in pool], "fitted": fitted.tolist(), "effects": []}
    for kind in ("inc", "azi"):
        m = chk.kind == kind
        if m.any():
            out[f"{kind}_rms_before"] = sel.rms(y[m])
            out[f"{kind}_rms_after"] = sel.rms(resid[m])
    if not accepted:
        out["best_model_not_accepted"] = {"terms": s.chosen, "loo_rms": s.loo_rms,
                                          "nested_loo_rms": s.nested_loo_rms,
                                          "why": "its nested leave-one-out does not beat the no-error model by "
                                                 "more than one standard error"}
        return out
    drops = {d["term"]: d for d in s.drop_tests}
    for e in s.estimates:
        t = terms[pb.names.index(e["term"])]
        row = {"name": t[1], "axis": t[2], "units": t[3], "term": e["term"]}
        if "components" in e:
            row.update(estimate=e["magnitude"], components=e["components"], quantity="magnitude")
            comps = list(e["components"].values())
            # stderr of the magnitude, to first order
            v = np.array([c["value"] for c in comps])
            sd = np.array([c["stderr"] for c in comps])
            row["stderr"] = float(np.sqrt(np.sum((v * sd) ** 2)) / max(np.linalg.norm(v), 1e-300))
        else:
            row.update(estimate=e["value"], stderr=e["stderr"])
        d = drops.get(e["term"])
        if d is not None:
            row["asked_for_by_the_data"] = d["asked_for_by_the_data"]
            if not d["asked_for_by_the_data"]:
                row["rivals"] = {"model_without_it": d["model_without_it"],
                                 "its_loo_rms": d["model_without_it_loo_rms"],
                                 "its_group_rms": d["model_without_it_group_rms"],
                                 "nested_loo_rms_without_it_in_the_pool": d["nested_loo_rms_without"]}
        scan_row = next((x for x in scan_out.values() if x["term"] == e["term"]), None)
        if scan_row is not None:
            row["toolface_range"] = [scan_row["min"], scan_row["max"]]
        out["effects"].append(row)
    return out
