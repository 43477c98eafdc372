"""The analysis commands: attitude, bitexact, calibrate, diagnose.

`inclino calibrate RUN.csv --method M -o CAL.json [--json]` fits the raw
dataset with one method, writes CAL.json (atomically: a temporary file
renamed into place, so a failure leaves no partial file) and prints the fit
report (text, or one JSON object with --json).  Exit status:
0 the fit passed its checks; 1 written, but the report's verdict is FAIL
(the reasons are printed); 2 bad input (DataError); 3 calibration refused
(CalibrationError: singular, out of the firmware's range; every row one
orientation: the data do not determine the model).

`inclino diagnose DATA.csv [--json] [--plot DIR] [--cal CAL.json]` and
`--paper li2021|ren2014`.  Exit status: 0 the diagnosis ran (whatever it found; a run without
poses or with one triad gets the pose-free diagnosis); 2 bad input
(DataError: unreadable file, too few poses, poses that
cannot separate the effects asked about, a temperature that never changes
when a temperature effect is asked about, a --cal without temperature
terms, every row one orientation: the data do not determine the model).
Errors are one line, never a
traceback.
"""
from __future__ import annotations

import csv
import json
import sys

from inclino.cli.paths import Input
from inclino.cli.options import add_cal, add_json, add_output, add_plot, command, deprecated
from inclino.errors import CalibrationError, DataError

MAX_BOOTSTRAP = 1000  # refits at most (each is a whole fit: a bound on the time a typo can cost)


def _note_pose_free_options(args, ds) -> None:
    """--prior, --mount-tolerance-deg and --accept-mount-tolerance act only on
    a fit without poses: given for one with poses they change nothing, and
    the technician is told so on stderr (the report's own note about the
    prior is not printed)."""
    if not getattr(ds, "has_pose", False) or getattr(args, "no_poses", False):
        return
    given = [opt for opt, on in (("--prior", getattr(args, "prior", None)),
                                 ("--mount-tolerance-deg", getattr(args, "mount_tolerance_deg", None) is not None),
                                 ("--accept-mount-tolerance", getattr(args, "accept_mount_tolerance", False)))
             if on]
    if given:
        print(f"inclino: note: {', '.join(given)} not used: the poses of {args.input} determine every coefficient "
              f"({'they act' if len(given) > 1 else 'it acts'} on a fit without poses: --no-poses, or a run "
              f"without pose columns)", file=sys.stderr)


def calibrate_main(args) -> int:
    import numpy as np

    from inclino.formats import dataset, safeio
    from inclino import progress

    from inclino.calib import common, fit
    from inclino.calib.thermal import NOT_FITTED as thermal_note

    safeio.check_output(args.output, [args.input, getattr(args, "prior", None)])  # before any work
    if getattr(args, "bootstrap", None) is not None and not 2 <= args.bootstrap <= MAX_BOOTSTRAP:
        raise DataError(f"--bootstrap {args.bootstrap}: refits, 2-{MAX_BOOTSTRAP}")
    ds = dataset.read_raw(args.input, progress=True)
    opts = {}
    if getattr(args, "no_poses", False):
        opts["use_poses"] = False
    if getattr(args, "prior", None):
        from inclino.formats.calfile import Calibration

        try:
            opts["prior"] = Calibration.load(args.prior)
        except (CalibrationError, DataError) as e:  # the prior is an input: a bad one is bad input
            raise DataError(f"--prior: {e}")
        if args.method != "joint":
            raise DataError("--prior is used by --method joint only")
    if getattr(args, "temperature_terms", None) is not None:
        if args.method != "joint":
            raise DataError("--temperature-terms is an option of --method joint")
        opts["temperature"] = args.temperature_terms
    if getattr(args, "mount_tolerance_deg", None) is not None:
        if not (args.mount_tolerance_deg >= 0 and np.isfinite(args.mount_tolerance_deg)):
            raise DataError("--mount-tolerance-deg must be a finite number >= 0")
        opts["mount_tolerance_deg"] = args.mount_tolerance_deg
    if getattr(args, "accept_mount_tolerance", False):
        opts["accept_mount_tolerance"] = True
    _note_pose_free_options(args, ds)
    if getattr(args, "bootstrap", None) is not None:
        opts["bootstrap"] = args.bootstrap
    if getattr(args, "static", False):
        opts["static"] = True
    from inclino.diagnose._blas import one_blas_thread

    try:
        # one BLAS thread (as diagnose): the fits work on matrices of tens of columns, and OpenBLAS's
        # worker threads only contend for them (on a loaded machine they doubled the CPU time of a long
        # temperature run's calibration)
        with progress.phase(f"calibrate: {args.method} fit of {args.input}"), one_blas_thread():
            cal, rep = fit(ds, args.method, data_hash=common.file_hash(args.input, ds), **opts)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as e:  # one line, never a traceback
        raise CalibrationError(f"{args.method}: the fit failed ({type(e).__name__}: {e})")
    cal.save(args.output, inputs=[args.input, getattr(args, "prior", None)])
    if args.json:
        print(json.dumps({"output": args.output, "method": cal.method, "probe_serial": cal.probe_serial,
                          "data": cal.data, "report": rep.to_dict(),
                          **({"temperature": cal.temperature} if cal.temperature else {})}, indent=2))
    else:
        print(f"{args.output}: {cal.method} calibration of probe {cal.probe_serial or '(no serial)'} "
              f"from {args.input} (sha256 {cal.data['sha256'][:16]}...)")
        print(rep.summary(verdict=False))
        if cal.temperature:
            from inclino.calib.thermal import summary

            print(summary(cal.temperature))
        for note in rep.notes:
            if note.startswith((dataset.THIN_NOTE, thermal_note)):
                print(f"  note: {note}")
        print(rep.conclusion())
    return 0 if rep.passed else 1


def add_calibrate(subparsers):
    from inclino.calib import DEFAULT_METHOD, METHODS

    c = command(subparsers, "calibrate", "fit a calibration to a raw dataset (writes CAL.json)",
                "Fit the probe's calibration (both triads' scale, misalignment and bias; with --method joint "
                "also their relative rotation and, when the run's temperatures determine them, temperature "
                "terms) to a raw dataset, write it as CAL.json and print the fit report: residuals, the "
                "predicted azimuth and inclination accuracy and its verdict. Exit 1: written, but the "
                "verdict is FAIL; exit 3: refused (singular, out of the firmware's range), nothing written.",
                ["inclino calibrate run.csv -o cal.json",
                 "inclino calibrate chamber.csv --method joint --temperature-terms on -o cal_t.json"])
    c.add_argument("input", action=Input, help="raw dataset CSV (docs/dataset.md)")
    c.add_argument("--method", choices=tuple(METHODS), default=DEFAULT_METHOD,
                   help="fitting method (default %(default)s)")
    add_output(c, "calibration file to write", metavar="CAL.json")
    add_json(c, "print the fit report as one JSON object")
    c.add_argument("--no-poses", action="store_true",
                   help="joint: ignore the pose columns (field recalibration from the invariants)")
    c.add_argument("--prior", metavar="CAL.json", action=Input,
                   help="joint without poses: take what the invariants cannot see (the common rotation "
                        "of the sensor block) from this turntable calibration of the same probe")
    c.add_argument("--temperature-terms", choices=("auto", "on", "off"), default=None,
                   help="joint: fit the temperature terms (auto, the default: when the run's temperatures determine "
                        "them; on: or refuse; off: never)")
    deprecated(c, "--temperature", "--temperature-terms", choices=("auto", "on", "off"))
    c.add_argument("--mount-tolerance-deg", type=float,
                   help="joint without poses or prior: 1-sigma of the sensor block's unobservable rotation, per axis: "
                        "its mounting and the accelerometer axes' own turn, in quadrature (default 0.3; "
                        "docs/calibration.md)")
    c.add_argument("--accept-mount-tolerance", action="store_true",
                   help="joint without poses or prior: accept that tolerance (the verdict then judges the fit itself)")
    c.add_argument("--bootstrap", type=int, help=f"paper methods: refits for the uncertainty, 2-{MAX_BOOTSTRAP} "
                                                 "(default 200)")
    c.add_argument("--static", action="store_true",
                   help="declare the run static (step-and-hold: every row at rest), whatever its time column")
    c.set_defaults(func=calibrate_main)
    return c


def _cmd_bitexact(args) -> int:
    from inclino.engines import bitexact

    if args.vectors < 0:
        raise DataError("--vectors must be >= 0")
    r = bitexact.run(args.vectors, args.seed)
    print(r.line)
    return 0 if r.mismatches == 0 else 1


ATTITUDE_CHUNK = 1 << 16  # rows computed and written at a time (bounded memory on a long run)


TEMP_SPAN_MARGIN_C = 5.0  # rows this far beyond the calibration run's temperatures are said to be extrapolated


def _outside_span(cal, temp, where) -> None:
    """A warning when temperatures the terms are applied at lie more than
    TEMP_SPAN_MARGIN_C beyond the span of the run they were fitted on
    (span_c): the polynomial is extrapolated there (85 and 120 degC on a run
    of -5.8 to 55.8 were applied without a word)."""
    import sys

    import numpy as np

    span = cal.temperature.get("span_c") if isinstance(cal.temperature, dict) else None
    if not span:
        return
    t = np.atleast_1d(np.asarray(temp, float))
    out = (t < span[0] - TEMP_SPAN_MARGIN_C) | (t > span[1] + TEMP_SPAN_MARGIN_C)
    if out.any() and np.ndim(temp) == 0:
        print(f"inclino: warning: --at-temperature {float(temp):g} degC is outside the calibration run's {span[0]:.1f} "
              f"to {span[1]:.1f} degC (by more than {TEMP_SPAN_MARGIN_C:g} degC): the temperature terms of {where} "
              f"are extrapolated there", file=sys.stderr)
    elif out.any():
        print(f"inclino: warning: {int(out.sum())} of {len(t)} row(s) at temperatures outside the calibration run's "
              f"{span[0]:.1f} to {span[1]:.1f} degC (by more than {TEMP_SPAN_MARGIN_C:g} degC; {t[out].min():.1f} to "
              f"{t[out].max():.1f} degC): the temperature terms of {where} are extrapolated there", file=sys.stderr)


def _cmd_attitude(args) -> int:
    import sys

    import numpy as np

    from inclino.formats import dataset, safeio
    from inclino.engines import attitude as engines
    from inclino.engines import temperature as te
    from inclino import progress
    from inclino.formats.calfile import Calibration

    safeio.check_output(args.output, [args.input, args.cal])  # before any work
    cal = Calibration.load(args.cal) if args.cal else Calibration()  # a refused file costs no reading
    at_t = getattr(args, "at_temperature", None)
    if at_t is not None and not (np.isfinite(at_t) and -100.0 <= at_t <= 300.0):
        raise DataError(f"--at-temperature {at_t:g}: a temperature in degC, -100 ... 300")
    ds = dataset.read_raw(args.input, progress=True)
    # with a calibration the raw readings' |g| and |b| warnings are the calibration's to correct: what it leaves
    # is checked on the corrected readings below (an LSM303's raw |b| 28 % low was warned of, corrected 46 958 nT)
    _checked(ds, fatal=False, unsaid=("units",) if args.cal else ())
    # what the data and the calibration both hold
    have = {"both": {"acc", "mag"}, "acc": {"acc"}, "mag": {"mag"}}
    common_ = have[ds.triads] & have[cal.triads]
    if not common_:
        raise DataError(f"{args.cal} calibrates the {'accelerometer' if cal.triads == 'acc' else 'magnetometer'} "
                        f"only, and {args.input} has no such columns")
    triads = "both" if common_ == {"acc", "mag"} else common_.pop()
    if triads != ds.triads:
        print(f"inclino: note: {args.cal} holds only the {'accelerometer' if triads == 'acc' else 'magnetometer'}: "
              f"only what it determines is written", file=sys.stderr)
    temp = None
    if te.has_terms(cal):
        if "temp_c" in ds.columns and at_t is None:
            temp = ds.columns["temp_c"]
        elif at_t is not None:
            temp = at_t
        else:
            raise DataError(f"{args.cal} has temperature terms and {args.input} has no temp_c column: give the "
                            f"probe's temperature with --at-temperature C (or apply a calibration without terms)")
    elif at_t is not None:
        print(f"inclino: note: {args.cal or 'the identity calibration'} has no temperature terms: "
              f"--at-temperature changes nothing", file=sys.stderr)
    if temp is not None:
        _outside_span(cal, temp, args.cal)
    cols = list(engines.COLS_BY_TRIADS[triads])
    notes: list = []
    kept = {c: [] for c in ("gt_g", "bt_nT", "dip_deg") if c in cols}  # a sample for the check after correcting
    step = max(1, len(ds) // 200_000)
    flagged: dict = {}  # flag bit -> rows that carry it
    with safeio.output_file(args.output, [args.input, args.cal]) as f, \
            progress.bar(len(ds), f"attitude {args.input}", unit=" rows") as bar:
        w = csv.writer(f)
        w.writerow(cols)
        acc = ds.acc if "acc" in have[triads] else None
        mag = ds.mag if "mag" in have[triads] else None
        for lo in range(0, len(ds), ATTITUDE_CHUNK):
            hi = min(lo + ATTITUDE_CHUNK, len(ds))
            t = temp[lo:hi] if isinstance(temp, np.ndarray) else temp
            out = engines.run_dataset(None if acc is None else acc[lo:hi], None if mag is None else mag[lo:hi],
                                      cal, args.engine, temp_c=t, triads=triads, notes=notes)
            text = {c: (out[c].astype(np.int64).astype(str) if c == "flags"
                        else np.char.mod("%.6f", np.asarray(out[c], dtype=float))) for c in cols}
            w.writerows(zip(*(text[c] for c in cols)))
            for c in kept:
                kept[c].append(np.asarray(out[c], dtype=float)[(-lo) % step::step])
            for bit in RANGE_FLAGS:
                flagged[bit] = flagged.get(bit, 0) + int(np.count_nonzero(np.asarray(out["flags"]) & bit))
            bar.update(hi - lo)
    for n in notes:
        print(f"inclino: note: {n}", file=sys.stderr)
    said = [f"{k} of {len(ds)} rows {RANGE_FLAGS[b]}" for b, k in flagged.items() if k]
    if said:
        print(f"inclino: note: {'; '.join(said)} (the flags column; docs/conventions.md): "
              + ("readings a probe would flag, computed in float all the same" if args.engine == "reference" else
                 f"the {args.engine} engine reads them as the probe would; --engine reference computes them in "
                 f"float"), file=sys.stderr)
    if args.cal:  # the identity's figures are the raw readings': the checks above looked at them
        from inclino import checks

        found = checks.corrected(ds.meta, *(np.concatenate(kept[c]) if c in kept else None
                                            for c in ("gt_g", "bt_nT", "dip_deg")), cal=args.cal)
        if found:
            print(f"inclino: warning: {found.message}", file=sys.stderr)
    return 0


# the flags that say a reading lies beyond the probe's own input (docs/conventions.md), as attitude names them
RANGE_FLAGS = {0x0002: "with an accelerometer count beyond the probe's +-1.7 g (ATT_F_ACC_OVERRANGE)",
               0x0004: "with a field reading beyond the probe's +-100 000 nT (ATT_F_MAG_OVERRANGE)",
               0x0008: "with an accelerometer mean at the int16 rail (ATT_F_ACC_SATURATED)",
               0x0010: "with a fluxgate count clamped to +-2^20 (ATT_F_MAG_SATURATED)",
               0x0020: "where a saturating operation clipped (ATT_F_ARITH_SATURATED)"}


def _checked(ds, static: bool = False, fatal: bool = True, unsaid=()):
    """inclino.checks on a dataset before a command uses it: data that cannot
    be right are one error line (exit 2) before any fit; `fatal` False (attitude,
    which fits nothing and computes each row as the probe would): said on
    stderr, and the rows are computed.  Warnings go to stderr, but for the
    checks named in `unsaid`."""
    import sys

    from inclino import checks

    found = checks.run(ds, declared_static=static)
    if fatal:
        found.raise_errors()
        levels = ("warning",)
    else:
        levels = ("error", "warning")
    for f in found.findings:
        if f.level in levels and not (f.level == "warning" and f.check in unsaid):
            print(f"inclino: {'warning' if f.level == 'error' else f.level}: {f.message}", file=sys.stderr)
    return found


def add_bitexact(sub):
    b = command(sub, "bitexact", "firmware C against the golden model, bit for bit",
                "Run the firmware's fixed-point C (compiled for the host) and the NumPy golden model on the "
                "same raw counts, the edge cases and --vectors random vectors, and compare every output bit "
                "for bit. Exit 1 on any mismatch.",
                ["inclino bitexact", "inclino bitexact --vectors 10000 --seed 7"])
    b.add_argument("--vectors", type=int, default=1_000_000,
                   help="random vectors besides the edge cases (default %(default)s)")
    b.add_argument("--seed", type=int, default=1, help="seed of the random vectors (default %(default)s)")
    b.set_defaults(func=_cmd_bitexact)


def add_attitude(sub):
    a = command(sub, "attitude", "attitude of every row of a raw dataset",
                "Compute the attitude (inclination, azimuth, toolface, G total, B total, dip, flags, magnetic "
                "toolface) of every row of a raw dataset through the firmware's C, the golden model or the "
                "float64 reference, with a calibration or the identity, and write it as CSV. With --cal, the corrected "
                "readings' median |g|, |b| and dip far from the header's gravity_g (1 g), field_nT and dip_deg (|b| "
                "from the geomagnetic range without one) are one warning on stderr: a calibration of another sensor "
                "or a stale one; the rows are still written (exit 0); the raw readings' own |g| and |b| warnings are "
                "then left to that check. Rows flagged beyond the probe's input range "
                "(ATT_F_*_OVERRANGE, *_SATURATED: another sensor's raw readings) are counted in one note on stderr. "
                "A one-triad dataset gives its triad's columns only: inc_deg, tf_deg, gt_g and flags from an "
                "accelerometer, bt_nT, mtf_deg and flags from a magnetometer (the azimuth and the dip need both).",
                ["inclino attitude run.csv --cal cal.json -o attitude.csv",
                 "inclino attitude run.csv --engine reference -o -"])
    a.add_argument("input", action=Input, help="raw dataset CSV")
    add_cal(a, "calibration to apply (default: the identity)")
    a.add_argument("--engine", choices=("firmware", "golden", "reference"), default="firmware",
                   help="the firmware's C, the NumPy golden model, or float64 (default %(default)s); every engine "
                        "applies every term of the calibration, its temperature terms from temp_c")
    a.add_argument("--at-temperature", type=float, metavar="C",
                   help="the probe's temperature (degC) for a calibration with temperature terms when the data "
                        "have no temp_c column (it also overrides temp_c)")
    add_output(a, "output CSV ('-' for stdout)", metavar="OUT.csv")
    a.set_defaults(func=_cmd_attitude)


PAPERS = ("li2021", "ren2014")


def diagnose_main(args) -> int:
    import numpy as np

    if args.paper:
        if args.input:
            raise DataError("give either a dataset or --paper, not both")
        from inclino.diagnose import papers, plots

        r = papers.reproduce(args.paper)
        print(r.to_json() if args.json else r.summary())
        if args.plot:
            for path in plots.write_paper(r, args.plot):
                if not args.json:
                    print(f"wrote {path}")
        return 0
    if not args.input:
        raise DataError("diagnose needs a raw dataset (DATA.csv) or --paper li2021|ren2014")
    from inclino.formats import dataset
    from inclino import progress

    from inclino.diagnose.analysis import diagnose

    ds = dataset.read_raw(args.input, progress=True)
    if getattr(args, "static", False):
        ds.meta["static"] = "true"
    found = _checked(ds, bool(getattr(args, "static", False)))
    thinned = None
    if getattr(args, "cal", None):
        # the correction is row by row: only the rows the diagnosis keeps are corrected (the same rows
        # diagnose() would keep: thin_rows depends on the row count alone), not a copy of the whole run
        from inclino.diagnose.analysis import MAX_ROWS

        ds, thinned = dataset.thin(ds, MAX_ROWS)
        ds = _temperature_corrected(ds, args.cal)
    pose_free = not ds.has_pose or ds.triads != "both"
    if pose_free and not _posefree_diagnosis_available():
        return _diagnose_invariants(ds, args, found)
    try:
        with np.errstate(all="ignore"), progress.phase(f"diagnose {args.input}"):
            r = diagnose(ds, effects=args.effects, alpha=args.alpha, folds=args.folds,
                         keep_plot_data=bool(args.plot), thinned=thinned, checks=found)
    except DataError as e:
        if pose_free and str(e).startswith("too few distinct orientations"):
            # too few orientations to test anything on the invariants (a six-face session): what each triad's
            # own fit leaves, nothing named
            return _diagnose_invariants(ds, args, found, refused=str(e))
        raise
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as e:  # one line, never a traceback
        raise DataError(f"diagnose failed on {args.input}: {type(e).__name__}: {e}")
    written = []
    if args.plot:
        from inclino.diagnose import plots

        if r.plot_data:
            written = plots.write(r, args.plot)
        else:
            _no_figures(args.plot, "the diagnosis kept nothing to plot")
    if args.json:
        print(r.to_json())
    else:
        for w in written:
            print(f"wrote {w}")
        print(f"{args.input}:")
        print(r.summary())  # its last line: the conclusion
    return 0


def _posefree_diagnosis_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("inclino.diagnose.posefree") is not None


def _no_figures(outdir, why: str) -> None:
    """--plot given where no figure is made: said in one line on stderr."""
    import sys

    print(f"inclino: note: --plot: no figures written to {outdir}: {why}", file=sys.stderr)


def _diagnose_invariants(ds, args, found=None, refused: str | None = None) -> int:
    """Data without the turntable's poses, or with one triad: the pose-based
    effect tests need both; what the invariants show is reported instead
    (each triad fitted on its own, |g|, |b| and the dip left over, each
    triad's noise, contiguous blocks of misfit as segments).  refused: why
    the pose-free diagnosis (the effect tests on the invariants) did not run
    (too few distinct orientations)."""
    import json as _json
    import re

    import numpy as np

    from inclino import progress
    from inclino.calib import fit
    from inclino.errors import CalibrationError

    if args.effects:
        raise DataError("--effects needs a dataset with both triads and the turntable's poses (inc_deg, azi_deg, "
                        "tf_deg): without them the invariants are reported")
    need = ["inc_deg", "tf_deg"] + (["azi_deg"] if ds.has_mag else [])
    missing = [c for c in need if c not in ds.columns]
    if missing and len(missing) < len(need):
        raise DataError(f"diagnose needs the turntable's pose for every reading, or no pose at all; missing "
                        f"column(s): {', '.join(missing)} (add them, or drop the other pose columns for the "
                        f"pose-free report)")
    poses = not missing
    why = ("one triad only (the effect tests need both)" if ds.triads != "both" and poses
           else "no turntable poses")
    try:
        with np.errstate(all="ignore"), progress.phase(f"diagnose {args.input}"):
            _, rep = fit(ds, "joint", use_poses=poses, accept_mount_tolerance=True, check=False,
                         static=bool(getattr(args, "static", False)))
    except (CalibrationError, ArithmeticError, ValueError, np.linalg.LinAlgError) as e:
        raise DataError(f"diagnose failed on {args.input}: {e}")
    note = (f"{why}: " + ("the residuals against the poses and the invariants after the triad's own fit"
                          if poses else "the invariants |g|, |b| and the dip after each triad's own fit")
            + "; no effect is named")
    from inclino.diagnose.runvars import drift_pose_confounds

    # what the settings of the pose cannot tell apart: a drift over the session against errors that depend on
    # the pose (a six-face session read face after face)
    confounded = drift_pose_confounds(ds) if poses else []
    # what the effect tests lack on these data: with poses, the other triad (the tests against the poses fit
    # both); without, the poses; and the tests on the invariants alone, enough distinct orientations
    other = "magnetometer" if ds.has_acc else "accelerometer"
    lack = (f"the run has no {other}, and the effect tests against the poses need both triads" if poses
            else "the run has no turntable poses")
    m = re.search(r": (\d+) \(needs (\d+)", refused or "")
    if m:
        lack += (f"; its {m.group(1)} distinct orientations are too few for the tests on the invariants alone "
                 f"(they need {m.group(2)})")
    conclusion = ("PASS: the invariants fit within their limits; no effect named" if rep.passed else
                  "FAIL: the invariants do not fit (" + "; ".join(rep.reasons) + f"); no effect named: {lack}")
    if args.plot:
        _no_figures(args.plot, f"no effect is tested on these data: {lack}")
    if args.json:
        from inclino.formats.jsonout import json_safe

        print(_json.dumps({"mode": "invariants", "note": note, "effects": [], "confounded": confounded,
                           "report": rep.to_dict(), "checks": json_safe(found.to_dict()) if found else None,
                           "conclusion": conclusion}))
    else:
        print(f"{args.input}:")
        print(f"  {note}")
        for c in confounded:
            print(f"  cannot be told apart on these {c['settings']} settings of the pose: {c['effect']} and "
                  f"{c['with']} (correlation {c['correlation']:.2f}); to separate them: {c['separate_by']}")
        print(rep.summary(verdict=False))
        print("conclusion: " + conclusion)
    return 0


def _temperature_corrected(ds, path):
    """The readings brought to the calibration's reference temperature with
    its temperature terms (CAL.json's temperature block, joint --temperature-terms):
    what the diagnosis then sees is what those terms leave."""
    from inclino.formats.calfile import Calibration
    from inclino.calib import thermal

    cal = Calibration.load(path)  # a corrupt calibration: exit 3, as for every command that reads one
    if not cal.temperature:
        raise DataError(f"{path} has no temperature terms (fit them with calibrate --method joint --temperature-terms)")
    if "temp_c" not in ds.columns:
        raise DataError("--cal: the data have no temp_c column to apply the temperature terms with")
    return thermal.corrected_dataset(ds, cal, cal.temperature)  # the block's rules: calfile.check_temperature


def add_diagnose(subparsers):
    from inclino.diagnose import EFFECT_NAMES

    p = command(subparsers, "diagnose", "find what the 12-parameter model gets wrong in a raw dataset, "
                                        "name the effect, measure the gain",
                "Fit the 12-parameter model to a raw dataset with the turntable's poses, test what its residuals "
                "hold against the candidate effects (temperature, nonlinearity, turntable errors, field drift, "
                "skew), name those that cross-validate at the --alpha false-alarm level, and say how much each "
                "would gain; outlier rows are listed. Without poses (or with one triad) it fits what the "
                "invariants (|g|, |b|, the dip) determine and tests them against the effects they can show "
                "(nonlinearity, temperature, field drift, a rig field), named the same way; with too few "
                "distinct orientations for that, each triad's own fit is reported and nothing is named. The "
                "checks before any fit (units, handedness, row alignment) run first. --paper compares the "
                "papers' own tables instead.",
                ["inclino diagnose run.csv", "inclino diagnose run.csv --plot figures --json",
                 "inclino diagnose --paper li2021"])
    p.add_argument("input", nargs="?", action=Input,
                   help="raw dataset CSV, with the turntable's poses or without (docs/dataset.md)")
    add_json(p)
    add_plot(p, "write PNGs of the residuals (before/after) into this folder")
    p.add_argument("--effects", help="comma-separated effects to test (default: all): " + ", ".join(EFFECT_NAMES))
    p.add_argument("--alpha", type=float, default=0.01,
                   help="false-alarm level: the chance of naming an effect on data without any (default %(default)s)")
    p.add_argument("--folds", type=int, default=5, help="cross-validation folds (default %(default)s)")
    add_cal(p, "first bring the readings to the reference temperature with this calibration's temperature "
               "terms (joint --temperature-terms): diagnose what they leave")
    p.add_argument("--static", action="store_true",
                   help="declare the run static (step-and-hold: every row at rest): no row is read as turning, "
                        "whatever the time column")
    p.add_argument("--paper", choices=PAPERS,
                   help="instead of a dataset: the papers' measured tables against the simulation (docs/diagnose.md)")
    p.set_defaults(func=diagnose_main)
    return p
