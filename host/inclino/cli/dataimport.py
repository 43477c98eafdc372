"""`inclino import LOG --sensor S.toml -o RUN.csv`: a log of any
accelerometer/magnetometer into the canonical dataset (docs/dataset.md),
checked before anything is fitted (inclino.checks).

Exit status: 0 written (warnings, if any, printed); 2 bad input: an
unreadable log or description, a column that is not there, data that cannot
be right (wrong units, an unintended reflection, a time unit by which the
sensor turns faster than 10^5 deg/s, a temperature column that is a copy of
a pose or sensor column, signed counts read as unsigned, filler rows, two
files paired in order at different rates): nothing is written then.  A
temperature column that is a counter or a ramp is a note (exit 0).
"""
from __future__ import annotations

import json


def import_main(args) -> int:
    from inclino.formats import dataset, importlog, safeio, sensor

    safeio.check_output(args.output, [args.log, args.sensor])
    desc = sensor.load(args.sensor) if args.sensor else sensor.default()
    from inclino import checks

    ds, rep = importlog.import_log(args.log, desc, static=True if args.static else None,
                                   drop_bad_rows=True if args.drop_bad_rows else None)
    found = checks.run(ds, declared_static=bool(args.static))
    found.raise_errors()  # data that cannot be right: exit 2, nothing written
    dataset.write_raw(args.output, ds, inputs=[args.log, args.sensor])
    if args.json:
        print(json.dumps({"output": args.output, **rep.to_dict(), "checks": found.to_dict()}, indent=2,
                         default=float))
    else:
        what = {"both": "accelerometer and magnetometer", "acc": "accelerometer only", "mag": "magnetometer only"}
        print(f"{args.output}: {rep.rows} rows ({what[rep.triads]}) from {args.log} through {desc.name}")
        for reason, n in rep.dropped.items():
            print(f"  dropped {n} row(s): {reason}")
        for note in rep.notes:
            print(f"  note: {note}")
        for line in found.lines(("warning", "note")):
            print(f"  {line}")
    return 0


def add_import(sub):
    from inclino.cli.options import add_json, add_output, command
    from inclino.cli.paths import Input

    p = command(sub, "import", "a log of any accelerometer/magnetometer into the canonical dataset, "
                               "through a sensor description (docs/dataset.md)",
                "Turn a log of any accelerometer and magnetometer (any columns, units and axis map; both triads "
                "or one) into the canonical raw dataset the other commands read, through a sensor description "
                "(a TOML file, or a preset citing its data sheet), and check it before anything is fitted: "
                "wrong units or an undeclared reflection of the axes is refused (exit 2, nothing written), and so "
                "are a temperature column that is a copy of a pose or sensor column, signed counts read as "
                "unsigned, filler rows (a run of identical rows, a time stamp that stops) and two files paired "
                "in order at different rates; a temperature column that is a counter or a ramp is a note (exit "
                "0). The header records the log (path, SHA-256) and the description.",
                ["inclino import log.csv --sensor mpu9250 -o run.csv",
                 "inclino import tests/data/real/ck_acc_mag/acc_mag_log.csv "
                 "--sensor tests/data/real/ck_acc_mag/sensor.toml -o run.csv"])
    p.add_argument("log", action=Input, help="the log: delimited text (comma, semicolon, tab or whitespace); a triad "
                   "logged to a file of its own is named in the description ([magnetometer] file = ...) and "
                   "paired with the log by time, or row by row")
    p.add_argument("--sensor", metavar="S.toml", action=Input,
                   help="sensor description (a TOML file, or a preset name: adis16210, mpu9250, icm20948, bno055; "
                        "default: adis16210, the canonical columns as they are)")
    add_output(p, "canonical dataset to write ('-' for stdout)", metavar="RUN.csv")
    p.add_argument("--static", action="store_true",
                   help="declare the run static (step-and-hold: every row at rest), recorded in the header")
    p.add_argument("--drop-bad-rows", action="store_true",
                   help="drop malformed rows (cells missing or not a number: a line garbled on a serial link), "
                        "counted with their line numbers, instead of refusing the first one; more than 5 %% of "
                        "the rows malformed is still refused; and filler rows (a run of rows identical, time stamp "
                        "and all; a time stamp that stops), whatever their share (as [log] bad_rows = \"drop\")")
    add_json(p, "print what the import did as one JSON object")
    p.set_defaults(func=import_main)
    return p
