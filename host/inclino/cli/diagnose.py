"""`inclino diagnose DATA.csv [--json] [--plot DIR] [--cal CAL.json]` and `--paper li2021|ren2014`.

Exit status: 0 the diagnosis ran (whatever it found); 2 bad input
(DataError: unreadable file, no pose columns, too few poses, poses that
cannot separate the effects asked about, a temperature that never changes
when a temperature effect is asked about, a --cal without temperature
terms).  Errors are one line, never a
traceback."""
from __future__ import annotations

import numpy as np

from inclino.errors import DataError

PAPERS = ("li2021", "ren2014")


def diagnose_main(args) -> int:
    if args.paper:
        if args.input:
            raise DataError("give either a dataset or --paper, not both")
        from inclino.diagnose import papers

        r = papers.reproduce(args.paper)
        print(r.to_json() if args.json else r.summary())
        if args.plot:
            for path in papers.write_plots(r, args.plot):
                if not args.json:
                    print(f"wrote {path}")
        return 0
    if not args.input:
        raise DataError("diagnose needs a raw dataset (DATA.csv) or --paper li2021|ren2014")
    from inclino.formats import dataset
    from inclino import progress

    from inclino.diagnose.analysis import diagnose

    ds = dataset.read_raw(args.input, progress=True)
    if getattr(args, "cal", None):
        ds = _temperature_corrected(ds, args.cal)
    try:
        with np.errstate(all="ignore"), progress.phase(f"diagnose {args.input}"):
            r = diagnose(ds, effects=args.effects, alpha=args.alpha, folds=args.folds,
                         keep_plot_data=bool(args.plot))
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as e:  # one line, never a traceback
        raise DataError(f"diagnose failed on {args.input}: {type(e).__name__}: {e}")
    written = []
    if args.plot:
        from inclino.diagnose import plots

        written = plots.write(r, args.plot)
    if args.json:
        print(r.to_json())
    else:
        print(f"{args.input}:")
        print(r.summary())
        for w in written:
            print(f"wrote {w}")
    return 0


def _temperature_corrected(ds, path):
    """The readings brought to the calibration's reference temperature with
    its temperature terms (CAL.json's temperature block, joint --temperature):
    what the diagnosis then sees is what those terms leave."""
    from inclino.formats.calfile import Calibration
    from inclino.calib import thermal
    from inclino.errors import CalibrationError

    try:
        cal = Calibration.load(path)
    except CalibrationError as e:
        raise DataError(str(e))
    if not cal.temperature:
        raise DataError(f"{path} has no temperature terms (fit them with calibrate --method joint --temperature)")
    if "temp_c" not in ds.columns:
        raise DataError("--cal: the data have no temp_c column to apply the temperature terms with")
    try:
        return thermal.corrected_dataset(ds, cal, cal.temperature)
    except (KeyError, TypeError, ValueError) as e:
        raise DataError(f"{path}: the temperature block is mangled ({e})")


def add_parser(subparsers):
    from inclino.diagnose import EFFECT_NAMES

    p = subparsers.add_parser("diagnose", help="find what the 12-parameter model gets wrong in a raw dataset, "
                                               "name the effect, measure the gain")
    p.add_argument("input", nargs="?", help="raw dataset CSV with the turntable's poses (docs/dataset.md)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="DIR", help="write PNGs of the residuals (before/after) into DIR")
    p.add_argument("--effects", help="comma-separated effects to test (default: all): " + ", ".join(EFFECT_NAMES))
    p.add_argument("--alpha", type=float, default=0.01,
                   help="false-alarm level: the chance of naming an effect on data without any (default 0.01)")
    p.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    p.add_argument("--cal", metavar="CAL.json",
                   help="first bring the readings to the reference temperature with this calibration's "
                        "temperature terms (joint --temperature): diagnose what they leave")
    p.add_argument("--paper", choices=PAPERS,
                   help="instead of a dataset: the papers' measured tables against the simulation (docs/diagnose.md)")
    p.set_defaults(func=diagnose_main)
    return p
