"""The S08 tooling's command: `python -m inclino.cli.s08 build OUTDIR
[--program harness|float]` (the image and its sizes; CMake's s08 target) and
`python -m inclino.cli.s08 bench` (the figures of `inclino bench mcu`)."""
from __future__ import annotations

import argparse
import json
from dataclasses import asdict


def main(argv=None) -> int:
    """`python -m inclino.cli.s08 build OUTDIR` (what CMake's s08 target runs) or
    `python -m inclino.cli.s08 bench`."""
    from inclino.benchmarks.s08 import bench
    from inclino.s08.sizes import sizes
    from inclino.s08.toolchain import build, tools_missing

    p = argparse.ArgumentParser(prog="python -m inclino.cli.s08")
    sub = p.add_subparsers(dest="cmd", required=True)
    pb = sub.add_parser("build", help="build the S08 harness image and print its sizes")
    pb.add_argument("outdir")
    pb.add_argument("--program", choices=("harness", "float"), default="harness")
    sub.add_parser("bench", help="print the figures of `inclino bench mcu --json`")
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
