"""`python -m inclino.cli.bench_temperature [--json] [--probes N] [--seed S]
[--average N] [--noise-free-run]`: the temperature section of `inclino bench
calibration` over more probes (each probe's worst ratio, its spread and the
fitted tail to the 1.2x target); with `--verdicts` the verdicts of `inclino
accept --temperatures` (its defaults) for probes as fitted and with their
terms scaled instead (docs/calibration.md).  Exit status 0, or 1 when the
target is not met; 2 on bad arguments."""
from __future__ import annotations

import argparse
import json
import sys


def build_parser() -> argparse.ArgumentParser:
    from inclino.benchmarks import calibration_temperature as bench_temp
    from inclino.cli.options import HelpFormatter

    p = argparse.ArgumentParser(prog="python -m inclino.cli.bench_temperature",
                                description=" ".join(__doc__.split("\n\n")[0].split()), formatter_class=HelpFormatter,
                                epilog="examples:\n  python -m inclino.cli.bench_temperature --probes 4\n"
                                       "  python -m inclino.cli.bench_temperature --verdicts --probes 6 --seed 3000")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--probes", type=int, default=bench_temp.N_PROBES, help="probes drawn (default %(default)s)")
    p.add_argument("--seed", type=int, default=bench_temp.SEED0, help="first seed (default %(default)s)")
    p.add_argument("--average", type=int, help="the chamber run's samples per reading (default: the procedure's, 64)")
    p.add_argument("--noise-free-run", action="store_true", help="the chamber run without sensor noise (what the "
                                                                  "noise costs the terms)")
    p.add_argument("--verdicts", action="store_true", help="instead: accept --temperatures's verdicts for probes "
                                                           "as fitted and with their terms scaled")
    return p


def temperature_main(argv=None) -> int:
    """The temperature bench with its sizes chosen, or accept's verdicts."""
    from inclino.benchmarks import calibration_temperature as bench_temp

    p = build_parser()
    a = p.parse_args(argv)
    if not 1 <= a.probes <= 10000:
        print("inclino: error: --probes must be within 1-10000", file=sys.stderr)
        return 2
    if a.average is not None and not 1 <= a.average <= 64:
        print("inclino: error: --average must be within 1-64 samples", file=sys.stderr)
        return 2
    if a.verdicts:
        v = bench_temp.accept_verdicts(a.probes, a.seed)
        print(json.dumps(v) if a.json else bench_temp.verdicts_text(v))
        return 0
    t = bench_temp.bench_temperature(a.probes, a.seed, average=a.average, run_noise=not a.noise_free_run)
    print(t.to_json() if a.json else bench_temp.text(t))
    return 0 if t.passed else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(temperature_main(sys.argv[1:]))
