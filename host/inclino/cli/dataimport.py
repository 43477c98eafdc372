"""`inclino import LOG --sensor S.toml -o RUN.csv`: a log of any
accelerometer/magnetometer into the canonical dataset (docs/dataset.md),
checked before anything is fitted (inclino.checks).

Exit status: 0 written (warnings, if any, printed); 2 bad input: an
unreadable log or description, a column that is not there, data that cannot
be right (wrong units, an unintended reflection): nothing is written then.
"""
from __future__ import annotations

import json


def import_main(args) -> int:
    from inclino.formats import dataset, importlog, safeio, sensor

    safeio.check_output(args.output, [args.log, args.sensor])
    desc = sensor.load(args.sensor) if args.sensor else sensor.default()
    ds, rep = importlog.import_log(args.log, desc, static=True if args.static else None)
    dataset.write_raw(args.output, ds, inputs=[args.log, args.sensor])
    if args.json:
        print(json.dumps({"output": args.output, **rep.to_dict()}, indent=2))
    else:
        print(f"{args.output}: {rep.rows} rows ({'accelerometer and magnetometer' if rep.triads == 'both' else ('accelerometer only' if rep.triads == 'acc' else 'magnetometer only')}) "
              f"from {args.log} through {desc.name}")
        for reason, n in rep.dropped.items():
            print(f"  dropped {n} row(s): {reason}")
    return 0


def add_import(sub):
    p = sub.add_parser("import", help="a log of any accelerometer/magnetometer into the canonical dataset, "
                                      "through a sensor description (docs/dataset.md)")
    p.add_argument("log", help="the log: delimited text (comma, semicolon, tab or whitespace)")
    p.add_argument("--sensor", metavar="S.toml",
                   help="sensor description (a TOML file, or a preset name: adis16210, mpu9250, icm20948, bno055; "
                        "default: adis16210, the canonical columns as they are)")
    p.add_argument("-o", "--output", required=True, help="canonical dataset to write (RUN.csv; '-' for stdout)")
    p.add_argument("--static", action="store_true",
                   help="declare the run static (step-and-hold: every row at rest), recorded in the header")
    p.add_argument("--json", action="store_true", help="print what the import did as one JSON object")
    p.set_defaults(func=import_main)
    return p
