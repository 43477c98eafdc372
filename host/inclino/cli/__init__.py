"""The `inclino` command: a thin shell over the library.

One module a role, each adding its subcommands and holding their handlers
(argument checks, printing); the library is imported only when a command
runs, so `inclino --help` stays fast:
  probe.py       identify, survey, download, verify, flash (the probe over its link)
  procedures.py  acquire, accept, plot, demo (procedures on a turntable)
  analysis.py    attitude, bitexact, calibrate, diagnose (files in, results out)
  dataimport.py  import (a log of any sensor into the canonical dataset)
  survey.py      reffield, toolmodel, trajectory, compare
  benchmarks.py  bench NAME (one function a name)
  emulate.py     emulate (the emulated probe on a pseudo-terminal)
  s08.py         python -m inclino.cli.s08 build|bench (the S08 simulator image)

Exit statuses: 0 success; 1 a check ran and failed; 2 bad input (file,
column, value, option); 3 calibration refused; 4 probe or port problem;
130 interrupted (Ctrl-C).  Every error is one line on stderr, never a
traceback: an option-parsing error too (`inclino: error: COMMAND: ...`,
exit 2), and Ctrl-C at any moment, from the first line of the entry point
(inclino.entry) on.

Every file a command reads or writes is declared with the actions of
inclino.cli.paths; `main` runs the command inside safeio.command_files, so
that no output replaces an input or another output (docs/cli.md, "Output
files").
"""
from __future__ import annotations

import argparse
import sys

from inclino import __version__
from inclino.cli import analysis, benchmarks, dataimport, emulate, probe, procedures, survey
from inclino.errors import DataError, InclinoError


class Parser(argparse.ArgumentParser):
    """argparse with one error line (`inclino: error: COMMAND: message`,
    exit 2) in place of the usage block; --help still prints it all."""

    def error(self, message):
        words = self.prog.split()
        where = " ".join(words[1:])
        raise DataError(f"{where + ': ' if where else ''}{message} (see {self.prog} --help)")


def build_parser() -> argparse.ArgumentParser:
    from inclino.cli.options import HelpFormatter

    p = Parser(
        prog="inclino", formatter_class=HelpFormatter,
        description="Toolkit for magnetic borehole inclinometer probes: talk to the probe, calibrate it on a "
                    "turntable, check the result, diagnose what a model misses, turn surveys into a well path. "
                    "`inclino COMMAND --help` describes a command with an example; docs/cli.md has them all.",
        epilog="to start, with no probe: the emulated one and the technician's loop it prints:\n"
               "  inclino emulate --unthrottled --link probe\n\n"
               "or the whole calibration bench in one command:\n  inclino demo")
    p.add_argument("--version", action="version", version=f"inclino {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    # the order `inclino --help` lists them
    procedures.add_demo(sub)
    analysis.add_bitexact(sub)
    analysis.add_attitude(sub)
    emulate.add_emulate(sub)
    benchmarks.add_bench(sub, cli_main=main)
    dataimport.add_import(sub)
    analysis.add_calibrate(sub)
    analysis.add_diagnose(sub)
    probe.add_flash(sub)
    probe.add_parser(sub)
    procedures.add_acquire(sub)
    procedures.add_accept(sub)
    procedures.add_plot(sub)
    survey.add_parser(sub)
    return p


def _run(argv):
    from inclino.cli.paths import command_parser, declared
    from inclino.formats import safeio

    parser = build_parser()
    args = parser.parse_args(argv)
    inputs, outputs = declared(command_parser(parser, args), args)
    with safeio.command_files(inputs, outputs):
        return int(args.func(args))


def main(argv: list[str] | None = None) -> int:
    """Run one command: its exit status; every failure is one line on stderr."""
    try:
        return _run(argv)
    except InclinoError as e:
        print(f"inclino: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt as e:   # a command may say what the interruption left (inclino flash)
        return interrupted(e)
    except BrokenPipeError:
        return 0
    except MemoryError:  # one line, never a traceback (docs/cli.md: exit 2)
        print("inclino: error: out of memory: the input is too large for this machine's memory limit",
              file=sys.stderr)
        return 2


def interrupted(e: BaseException | None = None) -> int:
    """Ctrl-C: one line (what the command says the interruption left, if
    anything), exit 130; a second Ctrl-C while it is printed is ignored."""
    import signal

    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # not the main thread
        old = None
    text = str(e) if e is not None else ""
    try:
        print("inclino: interrupted" + (f": {text}" if text else ""), file=sys.stderr)
    except (OSError, ValueError):
        pass
    finally:
        if old is not None:
            signal.signal(signal.SIGINT, old)
    return 130


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
