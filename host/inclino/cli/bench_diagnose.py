"""`python -m inclino.cli.bench_diagnose [--json] [--quick] [--per-size N]
[--nulls N] [--pairs N] [--seed S] [--cases]`: the diagnosis benchmark
(`inclino bench diagnose`) with its sizes chosen; with `--near-limit
Z[,Z...] [--draws N] [--effects E,...]` the miss rate just above the
detection limit instead (docs/diagnose.md); with `--real-only [--seed S]
[--per-size N] [--nulls N] [--logs NAME,...]` the real-data section alone.  Exit status 0, or 1 when the
benchmark's targets are not met; 2 on bad arguments."""
from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    from inclino.benchmarks.diagnose import __doc__ as doc
    from inclino.cli.options import HelpFormatter

    p = argparse.ArgumentParser(prog="python -m inclino.cli.bench_diagnose", description=doc.split("\n\n")[0],
                                formatter_class=HelpFormatter,
                                epilog="examples:\n  python -m inclino.cli.bench_diagnose --quick\n"
                                       "  python -m inclino.cli.bench_diagnose --near-limit 6,7.5,9 --draws 50")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quick", action="store_true", help="a small set (for the tests; not the targets' figures)")
    p.add_argument("--per-size", type=int, help="datasets per effect and size (default 4; quick 1)")
    p.add_argument("--nulls", type=int, help="null datasets (default 480; quick 12)")
    p.add_argument("--pairs", type=int, help="two-effect datasets (default 12; quick 2)")
    p.add_argument("--seed", type=int, help="first seed (default 1000; with --real-only 2024)")
    p.add_argument("--cases", action="store_true", help="with --json: every dataset's record too")
    p.add_argument("--near-limit", metavar="Z[,Z...]", help="instead: the miss rate at these sizes just above the "
                   "detection limit, per effect and plan (e.g. 6,7.5,9; what the hidden-effect tests' range rests on)")
    p.add_argument("--draws", type=int, default=100, help="with --near-limit: datasets per effect, plan and z "
                   "(default %(default)s)")
    p.add_argument("--effects", help="with --near-limit: only these effects (comma-separated)")
    p.add_argument("--real-only", action="store_true", help="only the real-data section (the corpus in "
                   "tests/data/real: injected effects, resampled untouched logs, held-out prediction); there "
                   "--per-size is the injections per effect and log (default 2), --nulls the resamplings per log "
                   "(default 12)")
    p.add_argument("--logs", metavar="NAME[,NAME...]", help="with --real-only: only the corpus logs whose names "
                   "start with these (e.g. mpu6050,sap6/BB); each keeps the draws it has in the whole section")
    return p


def diagnose_main(argv=None) -> int:
    """The diagnosis benchmark with its sizes chosen, or its near-limit miss rates."""
    from inclino.benchmarks.diagnose import bench_diagnose

    p = build_parser()
    a = p.parse_args(argv)
    if a.near_limit is not None:
        from inclino.benchmarks.diagnose import EFFECT_PLANS, near_limit, near_limit_text
        from inclino.formats.jsonout import dumps

        try:
            zs = [float(z) for z in a.near_limit.split(",")]
        except ValueError:
            p.error(f"--near-limit takes comma-separated sizes, not {a.near_limit!r}")
        effects = [e.strip() for e in a.effects.split(",")] if a.effects else None
        unknown = [e for e in effects or () if e not in EFFECT_PLANS]
        if unknown or not zs or min(zs) <= 0 or a.draws < 1:
            p.error(f"unknown effect {unknown[0]!r}" if unknown else "--near-limit sizes and --draws must be > 0")
        r = near_limit(zs, a.draws, 1000 if a.seed is None else a.seed, effects)
        print(dumps(r) if a.json else near_limit_text(r))
        return 0
    if a.real_only:
        from inclino.benchmarks.diagnose_real import bench_real
        from inclino.diagnose._blas import one_blas_thread

        if (a.per_size is not None and a.per_size < 0) or (a.nulls is not None and a.nulls < 0):
            p.error("--per-size and --nulls must be >= 0")
        with one_blas_thread():
            r = bench_real(seeds=2 if a.per_size is None else a.per_size,
                           resamplings=12 if a.nulls is None else a.nulls,
                           seed0=2024 if a.seed is None else a.seed, quick=a.quick,
                           logs=[x.strip() for x in a.logs.split(",") if x.strip()] if a.logs else None)
        if a.logs and r.note.startswith("no corpus log"):
            p.error(r.note)
        print(r.to_json() if a.json else "\n".join(r.lines()))
        return 0 if r.passed else 1
    r = bench_diagnose(a.quick, a.per_size, a.nulls, a.pairs, 1000 if a.seed is None else a.seed)
    print(r.to_json(cases=a.cases) if a.json else r.summary())
    return 0 if r.passed else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(diagnose_main())
