"""Mutation testing of the core modules with cosmic-ray (docs/testing.md).

    .venv/bin/pip install cosmic-ray
    nice -n 19 .venv/bin/python tools/mutation.py [--sample N] [--seed S] [MODULE ...]

For each module: a cosmic-ray session over every mutation its operators
make, of which a seeded random sample of N is run (all when N is 0: a
module has hundreds to a thousand mutants, each a pytest run of the
module's own tests, a few seconds each); the others are recorded as
skipped.  The mutations are made in a scratch clone of the checkout
(cosmic-ray edits the files in place), with the compiled extensions
copied in and the clone's sources first on PYTHONPATH.  Prints per module
the kill ratio over the run sample and the surviving mutations (file, line,
operator, the diff), and writes them as JSON to --out.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PYTEST = "python -m pytest -x -q -p no:randomly -p no:cacheprovider -p no:xdist"

# module -> the tests that exercise it (run for every mutant: the module's own, not the suite)
MODULES = {
    "diagnose/robust.py": "tests/test_diagnose_robust.py tests/test_diagnose_hidden.py",
    "survey/geomag.py": "tests/test_survey_trajectory.py -k 'geomag or declination or gravity or altitude or wmm "
                        "or grid or reference or convergence'",
    "formats/dataset.py": "tests/test_hostile_files.py tests/test_dataset_cli.py",
    "formats/calimage.py": "tests/test_calimage.py",
    "link/protocol.py": "tests/test_protocol_frames.py tests/test_protocol_commands.py",
}


def _clone(dest: str) -> None:
    subprocess.run(["git", "clone", "-q", ROOT, dest], check=True)
    # the working tree's own (possibly uncommitted) sources and tests, and the compiled extensions
    for sub in ("host", "emulator", "tests"):
        shutil.copytree(os.path.join(ROOT, sub), os.path.join(dest, sub), dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns("__pycache__"))


def _session(work: str, module: str, tests: str, sample: int, seed: int, timeout: float) -> str:
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    name = module.replace("/", "_").replace(".py", "")
    cfg = os.path.join(work, f"{name}.toml")
    db = os.path.join(work, f"{name}.sqlite")
    with open(cfg, "w") as f:
        f.write(f'[cosmic-ray]\nmodule-path = "host/inclino/{module}"\ntimeout = {timeout}\n'
                f'excluded-modules = []\ntest-command = "{PYTEST} {tests}"\n'
                '[cosmic-ray.distributor]\nname = "local"\n')
    src = os.path.join(work, "src")
    base = subprocess.run(f"{PYTEST} {tests}", shell=True, cwd=src, capture_output=True, text=True)
    if base.returncode != 0:  # every mutant would count as killed
        raise SystemExit(f"{module}: its tests fail before any mutation:\n{base.stdout[-3000:]}")
    subprocess.run(["cosmic-ray", "init", cfg, db], check=True, cwd=src)
    if sample:
        with use_db(db, WorkDB.Mode.open) as wdb:
            ids = sorted(w.job_id for w in wdb.pending_work_items)
            keep = set(random.Random(f"{seed}:{module}").sample(ids, min(sample, len(ids))))
            skip = [i for i in ids if i not in keep]
            wdb.set_multiple_results(skip, WorkResult(output="not in the sample", worker_outcome=WorkerOutcome.SKIPPED))
    return cfg, db


def _again(work: str, module: str):
    """The kept session of a module with its survivors' results cleared."""
    import sqlite3

    name = module.replace("/", "_").replace(".py", "")
    cfg, db = os.path.join(work, f"{name}.toml"), os.path.join(work, f"{name}.sqlite")
    src = os.path.join(work, "src")
    base = subprocess.run(f"{PYTEST} {MODULES[module]}", shell=True, cwd=src, capture_output=True, text=True)
    if base.returncode != 0:  # the current tests against the kept sources: every mutant would count as killed
        raise SystemExit(f"{module}: the current tests fail on the kept (unmutated) sources; start a new "
                         f"session:\n{base.stdout[-3000:]}")
    with sqlite3.connect(db) as c:
        c.execute("DELETE FROM work_results WHERE test_outcome = 'SURVIVED'")
    return cfg, db


def _report(module: str, db: str) -> dict:
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome

    with use_db(db, WorkDB.Mode.open) as wdb:
        specs = {w.job_id: w.mutations[0] for w in wdb.work_items}
        run = killed = 0
        survivors = []
        for job_id, r in wdb.results:
            if r.worker_outcome == WorkerOutcome.SKIPPED:
                continue
            run += 1
            if r.is_killed:
                killed += 1
            else:
                m = specs[job_id]
                survivors.append({"line": m.start_pos[0], "operator": m.operator_name,
                                  "diff": "\n".join(l for l in (r.diff or "").splitlines()
                                                    if l.startswith(("+", "-")) and not l.startswith(("+++", "---")))})
    return {"module": module, "mutants": len(specs), "run": run, "killed": killed,
            "kill_ratio": killed / run if run else None, "survivors": sorted(survivors, key=lambda s: s["line"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("modules", nargs="*", default=list(MODULES), help="modules under host/inclino (default: all)")
    ap.add_argument("--sample", type=int, default=60, help="mutants run per module, a seeded sample (0: all)")
    ap.add_argument("--seed", type=int, default=25)
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per mutant before it counts as killed")
    ap.add_argument("--out", default="mutation.json")
    ap.add_argument("--keep", help="work in this folder and keep it (default: a temporary one)")
    ap.add_argument("--again", action="store_true",
                    help="with --keep: run the survivors of the kept sessions again against the checkout's "
                         "current tests (the same mutants: the after figure)")
    a = ap.parse_args(argv)
    if a.again and not a.keep:
        ap.error("--again needs --keep (the folder of the earlier run)")
    work = a.keep or tempfile.mkdtemp(prefix="inclino-mutation-")
    src = os.path.join(work, "src")
    if not os.path.isdir(src):
        _clone(src)
    elif a.again:
        shutil.copytree(os.path.join(ROOT, "tests"), os.path.join(src, "tests"), dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.join(src, "host"), os.path.join(src, "emulator")]))
    os.environ.update(env)
    results = []
    try:
        for module in a.modules:
            if a.again:
                cfg, db = _again(work, module)
            else:
                cfg, db = _session(work, module, MODULES[module], a.sample, a.seed, a.timeout)
            subprocess.run(["cosmic-ray", "exec", cfg, db], check=True, cwd=src, env=env)
            r = _report(module, db)
            results.append(r)
            print(f"{module}: {r['killed']} of {r['run']} mutants killed ({100 * (r['kill_ratio'] or 0):.0f} %; "
                  f"{r['mutants']} in all, a seeded sample run)", flush=True)
            for s in r["survivors"]:
                print(f"  survived: line {s['line']} {s['operator']}\n    " + s["diff"].replace("\n", "\n    "))
            with open(a.out, "w") as f:
                json.dump(results, f, indent=1)
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
