"""`inclino calibrate RUN.csv --method M -o CAL.json [--json]`.

Fits the raw dataset with one method, writes CAL.json (atomically: a
temporary file renamed into place, so a failure leaves no partial file) and
prints the fit report (text, or one JSON object with --json).  Exit status:
0 the fit passed its checks; 1 written, but the report's verdict is FAIL
(the reasons are printed); 2 bad input (DataError); 3 calibration refused
(CalibrationError: singular, out of the firmware's range)."""
from __future__ import annotations

import json

import numpy as np

from inclino.errors import CalibrationError, DataError

from inclino.calib import DEFAULT_METHOD, METHODS


MAX_BOOTSTRAP = 1000  # refits at most (each is a whole fit: a bound on the time a typo can cost)


def calibrate_main(args) -> int:
    from inclino.formats import dataset, safeio
    from inclino import progress

    from inclino.calib import common, fit

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
        except CalibrationError as e:  # the prior is an input: a bad one is bad input
            raise DataError(f"--prior: {e}")
        if args.method != "joint":
            raise DataError("--prior is used by --method joint only")
    if getattr(args, "temperature", None) is not None:
        if args.method != "joint":
            raise DataError("--temperature is an option of --method joint")
        opts["temperature"] = args.temperature
    if getattr(args, "mount_tolerance_deg", None) is not None:
        if not (args.mount_tolerance_deg >= 0 and np.isfinite(args.mount_tolerance_deg)):
            raise DataError("--mount-tolerance-deg must be a finite number >= 0")
        opts["mount_tolerance_deg"] = args.mount_tolerance_deg
    if getattr(args, "accept_mount_tolerance", False):
        opts["accept_mount_tolerance"] = True
    if getattr(args, "bootstrap", None) is not None:
        opts["bootstrap"] = args.bootstrap
    try:
        with progress.phase(f"calibrate: {args.method} fit of {args.input}"):
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
        print(rep.summary())
        if cal.temperature:
            from inclino.calib.thermal import summary

            print(summary(cal.temperature))
        for note in rep.notes:
            if note.startswith(dataset.THIN_NOTE):
                print(f"  note: {note}")
    return 0 if rep.passed else 1


def add_parser(subparsers):
    c = subparsers.add_parser("calibrate", help="fit a calibration to a raw dataset (writes CAL.json)")
    c.add_argument("input", help="raw dataset CSV (docs/dataset.md)")
    c.add_argument("--method", choices=tuple(METHODS), default=DEFAULT_METHOD,
                   help=f"fitting method (default {DEFAULT_METHOD})")
    c.add_argument("-o", "--output", required=True, help="calibration file to write (CAL.json)")
    c.add_argument("--json", action="store_true", help="print the fit report as one JSON object")
    c.add_argument("--no-poses", action="store_true",
                   help="joint: ignore the pose columns (field recalibration from the invariants)")
    c.add_argument("--prior", help="joint without poses: take what the invariants cannot see (the common rotation "
                                   "of the sensor block) from this turntable calibration of the same probe")
    c.add_argument("--temperature", choices=("auto", "on", "off"), default=None,
                   help="joint: fit the temperature terms (auto, the default: when the run's temperatures determine "
                        "them; on: or refuse; off: never)")
    c.add_argument("--mount-tolerance-deg", type=float,
                   help="joint without poses or prior: 1-sigma of the sensor block's unobservable rotation, per axis "
                        "(default 0.3; docs/calibration.md)")
    c.add_argument("--accept-mount-tolerance", action="store_true",
                   help="joint without poses or prior: accept that tolerance (the verdict then judges the fit itself)")
    c.add_argument("--bootstrap", type=int, help="paper methods: refits for the uncertainty (default 40)")
    c.set_defaults(func=calibrate_main)
    return c
