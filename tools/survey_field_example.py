"""The field workflow of docs/survey.md, run on the emulated probe through the
real commands; writes the files docs/survey.md shows into docs/survey-field/.

    .venv/bin/python tools/survey_field_example.py [--seed N]

The emulated typical probe sits in the IGRF field of 52 N, 4 E on
2026-06-01; its turntable, moved over the emulator's control channel,
stands in for the hole (a build-and-hold well, stations every 30 m).
Steps, each an `inclino` command as a crew runs it:

1. reffield: the reference field, kept (ref.json) and stored on the probe;
2. acquire (bench) + calibrate + download: the probe's calibration;
3. survey --md M -o inrun.csv --las inrun.las --append: the in-run, going
   down, one station after another into the same two files;
4. the same coming out (outrun.csv, outrun.las: depth decreasing);
5. compare inrun.csv outrun.csv --cal cal.json;
6. trajectory inrun.csv --uncertainty with the probe's terms only, the
   standard ISCWSA MWD Rev 5.11 model, and the two together; the figure
   of their ellipses (docs/survey-ellipses.png).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "docs", "survey-field")


def main(argv=None) -> int:
    from inclino import cli
    from inclino.benchmarks import survey as sb
    from inclino.survey import geomag
    from inclino_emu.control import ControlClient
    from inclino_emu.runner import Emulator

    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=23)
    ap.add_argument("--out", default=OUT)
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    fig_path = os.path.abspath(os.path.join(a.out, "..", "survey-ellipses.png"))
    os.chdir(a.out)  # the commands below name the files as a crew in that directory would
    for f in os.listdir("."):
        if f.endswith((".csv", ".las", ".json", ".txt", ".part", ".toml")):
            os.unlink(os.path.join(a.out, f))
    rng = np.random.default_rng(a.seed)
    p = lambda name: name
    log = []

    def run(*args, ok=(0,)):
        o, e = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
            rc = cli.main([str(x) for x in args])
        shown = " ".join(str(x) for x in args)
        log.append(f"$ inclino {shown}\n{o.getvalue()}{e.getvalue()}")
        if rc not in ok:
            raise SystemExit(f"inclino {' '.join(map(str, args))}: exit {rc}: {e.getvalue()}")
        return o.getvalue()

    scen = sb.scenario_file(p("probe.toml"), geomag.normal_gravity_g(sb.LAT))
    md = np.arange(0.0, 600.0 + 0.5, 30.0)
    inc, _, _, _ = sb.build_and_hold(md, 150.0, 3.0, 30.0, 60.0)
    e = sb.load_field(scen)
    azi_mag = (60.0 - e[2]) % 360.0
    with Emulator(scen, seed=a.seed, control_port=0, realtime=False) as emu:
        ctl = ControlClient(port=emu.control_port)
        port, bench = emu.path, f"127.0.0.1:{emu.control_port}"  # printed as P and B in session.txt
        run("reffield", "--lat", sb.LAT, "--lon", sb.LON, "--date", sb.DATE, "-o", p("ref.json"), "--port", port)
        run("acquire", "--port", port, "--bench", bench, "--procedure", "multi-position", "--points", 12,
            "-o", p("calrun.csv"), "--quiet")
        run("calibrate", p("calrun.csv"), "--method", "joint", "-o", p("cal.json"), ok=(0, 1))
        run("download", "--port", port, "--cal", p("cal.json"), "--quiet")
        for name, order in (("inrun", range(len(md))), ("outrun", reversed(range(len(md))))):
            for n, i in enumerate(order):
                ctl.call("move", inc=float(inc[i]), azi=60.0, tf=float(rng.uniform(0, 360)))
                o, e2 = io.StringIO(), io.StringIO()
                with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e2):
                    cli.main(["survey", "--port", port])  # the first survey after a move settles the filters
                run("survey", "--port", port, "--md", md[i], "--count", 2, "-o", p(f"{name}.csv"), "--las",
                    p(f"{name}.las"), *(["--append"] if n else []))
        ctl.close()
    run("compare", p("inrun.csv"), p("outrun.csv"), "--cal", p("cal.json"), ok=(0, 1))
    run("toolmodel", "--cal", p("cal.json"), "--ref", p("ref.json"), "-o", p("probe-tool.json"), ok=(0, 1))
    for name, args in (("probe", ["--tool-model", p("probe-tool.json"), "--ref-terms", "none"]),
                       ("mwd", ["--tool-model", "iscwsa-mwd-rev5"]),
                       ("complete", ["--tool-model", "iscwsa-mwd-rev5", "--cal", p("cal.json")])):
        run("trajectory", p("inrun.csv"), "--ref", p("ref.json"), "--uncertainty", *args,
            "-o", p(f"trajectory-{name}.csv"), *(["--las", p("trajectory-complete.las")] if name == "complete" else []))
    run("trajectory", p("outrun.csv"), "--ref", p("ref.json"), "-o", p("trajectory-outrun.csv"))
    with open(p("session.txt"), "w", encoding="utf-8") as f:
        f.write("\n".join(log).replace(port, "P").replace(bench, "B"))
    for f in ("probe.toml", "calrun.csv"):
        os.unlink(p(f))
    _figure(p, fig_path)
    print(f"wrote {a.out}")
    return 0


def _figure(p, path):
    from inclino import plotting
    from inclino.survey import wellpath as wp

    plt = plotting.pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    for name, label, style in (("probe", "the probe's terms alone (its calibration's covariance and measured noise)", "C0-"),
                               ("mwd", "ISCWSA MWD Rev 5.11 (standard)", "C1--"),
                               ("complete", "ISCWSA MWD Rev 5.11 with the probe's sensor terms", "C2-")):
        rows = wp.read_trajectory(p(f"trajectory-{name}.csv"))
        md = [float(r["md_m"]) for r in rows]
        ax[0].plot(md, [float(r["ell_major_m"]) for r in rows], style, label=label)
        ax[1].plot(md, [float(r["sigma_tvd_m"]) for r in rows], style, label=label)
    ax[0].set(xlabel="measured depth, m", ylabel="1-sigma ellipse, semi-major axis, m", yscale="log")
    ax[1].set(xlabel="measured depth, m", ylabel="1-sigma TVD, m", yscale="log")
    ax[0].legend(fontsize=8)
    fig.suptitle("emulated probe, build-and-hold in-run (docs/survey-field): the probe's ellipse next to the standard "
                 "MWD one", fontsize=9)
    fig.tight_layout()
    plotting.save(fig, path)


if __name__ == "__main__":
    sys.exit(main())
