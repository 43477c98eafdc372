"""The S08 tooling's command: `python -m inclino.cli.s08 build OUTDIR
[--program harness|float]` (the image and its sizes; CMake's s08 target) and
`python -m inclino.cli.s08 bench` (the figures of `inclino bench mcu`)."""
from __future__ import annotations

import argparse
import json
from dataclasses import asdict


def build_parser() -> argparse.ArgumentParser:
    from inclino.cli.options import HelpFormatter

    p = argparse.ArgumentParser(prog="python -m inclino.cli.s08", formatter_class=HelpFormatter,
                                description="The firmware's core built for the S08 and run on its simulator "
                                            "(SDCC and uCsim, Debian packages): build the image and print its "
                                            "sizes, or print the figures of `inclino bench mcu --json`.",
                                epilog="examples:\n  python -m inclino.cli.s08 build build/s08\n"
                                       "  python -m inclino.cli.s08 bench")
    sub = p.add_subparsers(dest="cmd", required=True)
    pb = sub.add_parser("build", help="build the S08 harness image and print its sizes", formatter_class=HelpFormatter,
                        description="Build the S08 image (the harness, or the float build for comparison) into "
                                    "OUTDIR and print its Intel HEX path and its sizes per module as JSON.",
                        epilog="example:\n  python -m inclino.cli.s08 build build/s08 --program float")
    pb.add_argument("outdir", help="folder for the object files and the image")
    pb.add_argument("--program", choices=("harness", "float"), default="harness",
                    help="the fixed-point harness or the float build (default %(default)s)")
    sub.add_parser("bench", help="print the figures of `inclino bench mcu --json`", formatter_class=HelpFormatter,
                   description="Build the harness, run it on the simulator and print the cycles and sizes as "
                               "one JSON object (what `inclino bench mcu --json` prints).",
                   epilog="example:\n  python -m inclino.cli.s08 bench")
    return p


def main(argv=None) -> int:
    """`python -m inclino.cli.s08 build OUTDIR` (what CMake's s08 target runs) or
    `python -m inclino.cli.s08 bench`."""
    from inclino.benchmarks.s08 import bench
    from inclino.s08.sizes import sizes
    from inclino.s08.toolchain import build, tools_missing

    p = build_parser()
    a = p.parse_args(argv)
    reason = tools_missing()
    if reason:
        print(reason)
        return 2
    if a.cmd == "build":
        b = build(a.outdir, program=a.program)
        print(b.ihx)
        print(json.dumps(asdict(sizes(b)), indent=2))
    else:
        print(bench().to_json())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
