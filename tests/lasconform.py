"""A LAS 2.0 conformance check for the files the survey commands write.

Two independent views: the rules of lascheck (a LAS 2.0 conformity checker
on PyPI; MIT) that hold for any file -- mandatory sections and ~V/~W lines,
~V first, no duplicate sections, no section after ~A, no blank line inside
a section, a valid index mnemonic (DEPT, DEPTH, TIME, INDEX) and depth unit
-- and our reading of the CWLS LAS 2.0 text for what lascheck gets wrong or
leaves out: STRT and STOP are the first and last index values; STEP is the
constant spacing or, for irregular sampling, 0 (lascheck divides by STEP
and fails on 0, which the standard allows); STRT/STOP/STEP carry the index
unit; every ~A line has one value per curve; WRAP NO; VERS 2.0.
"""
from __future__ import annotations

import io


def conformance(text: str) -> list[str]:
    """The problems of a LAS 2.0 file's text (empty: it conforms)."""
    import contextlib

    import lascheck
    from lascheck import spec

    problems = []
    with contextlib.redirect_stdout(io.StringIO()):  # lascheck prints notes on missing optional sections
        las = lascheck.read(io.StringIO(text))
    for rule in (spec.MandatorySections, spec.MandatoryLinesInVersionSection, spec.MandatoryLinesInWellSection,
                 spec.DuplicateSections, spec.ValidIndexMnemonic, spec.ValidUnitForDepth, spec.VSectionFirst,
                 spec.BlankLineInSection):
        if not rule.check(las):
            problems.append(f"lascheck: {rule.__name__}")
    problems += _standard(text)
    return problems


def _standard(text: str) -> list[str]:
    lines = text.splitlines()
    sec, items, data, curves = None, {}, [], []
    for ln in lines:
        s = ln.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith("~"):
            sec = s[1].upper()
            continue
        if sec == "A":
            data.append(s.split())
            continue
        if sec in ("V", "W", "C", "P"):
            mnem, rest = s.split(".", 1)
            unit = rest.split(" ", 1)[0] if not rest.startswith(" ") else ""
            value = rest[len(unit):].rsplit(":", 1)[0].strip()
            items[(sec, mnem.strip().upper())] = (unit, value)
            if sec == "C":
                curves.append((mnem.strip().upper(), unit))
    out = []
    if items.get(("V", "VERS"), ("", ""))[1] != "2.0":
        out.append("VERS is not 2.0")
    if items.get(("V", "WRAP"), ("", ""))[1].upper() != "NO":
        out.append("WRAP is not NO")
    if not curves:
        return out + ["no curves"]
    if any(len(r) != len(curves) for r in data):
        out.append("an ~A line without one value per curve")
    if not data:
        return out
    null = float(items.get(("W", "NULL"), ("", "-999.25"))[1])
    idx = [float(r[0]) for r in data]
    if any(v == null for v in idx):
        out.append("a NULL index value")
    iu = curves[0][1]
    for k in ("STRT", "STOP", "STEP"):
        u, v = items.get(("W", k), (None, None))
        if u is None:
            out.append(f"{k} missing")
        elif u != iu:
            out.append(f"{k} unit {u!r} is not the index unit {iu!r}")
    strt, stop, step = (float(items[("W", k)][1]) for k in ("STRT", "STOP", "STEP"))
    if abs(strt - idx[0]) > 1e-9 * max(1.0, abs(idx[0])) or abs(stop - idx[-1]) > 1e-9 * max(1.0, abs(idx[-1])):
        out.append("STRT/STOP are not the first/last index values")
    d = [b - a for a, b in zip(idx, idx[1:])]
    regular = bool(d) and d[0] != 0 and all(abs(x - d[0]) <= 1e-6 * max(1.0, abs(d[0])) for x in d)
    if step == 0:
        if regular and len(d) > 1:
            out.append("STEP 0 for a regular index")
    elif not regular or abs(step - d[0]) > 1e-6 * abs(d[0]):
        out.append(f"STEP {step:g} but the index is {'irregular' if not regular else f'spaced {d[0]:g}'}")
    return out
