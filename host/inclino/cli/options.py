"""One name per quantity across the commands (CONTRIBUTING.md, "Options").

`command()` makes a subcommand's parser with its one-paragraph description
and an example; `add_port()`, `add_json()`, `add_cal()`, `add_output()`,
`add_plot()` declare the options every command spells the same way; and
`deprecated()` keeps an old spelling working as a hidden alias that says
its new name in one line on stderr.  tests/test_cli_options.py walks every
parser and checks these rules (help text, default shown, one name a
quantity, a description and an example a command).
"""
from __future__ import annotations

import argparse
import sys
import textwrap

# The canonical option of each quantity, and the spellings it replaced (kept
# as hidden aliases).  The parser walk (tests/test_cli_options.py) refuses a
# replaced spelling anywhere but as such an alias, and docs/cli.md lists them.
CANONICAL = {
    "--field": ("total field, nT", ("--total", "--field-total", "--total-field")),
    "--output": ("the file or folder a command writes (-o)", ("--out", "--save", "--outfile", "--output-file")),
    "--cal": ("the calibration file CAL.json", ("--calibration", "--cal-file")),
    "--plot": ("a folder for the PNG figures", ("--plot-dir", "--figures")),
    "--json": ("print JSON (one object, or JSON lines for a stream); no --format json", ()),
    "--period-ms": ("survey period, milliseconds", ("--period",)),
    "--interval-min": ("minutes between chamber readings", ("--interval",)),
    "--soak-window-min": ("the settling window, minutes", ("--soak-window",)),
    "--max-soak-min": ("give up a set point after this long, minutes", ("--max-soak",)),
    "--temperature-terms": ("calibrate: fit the temperature terms", ("--temperature",)),
    "--chamber": ("demo: the temperature step", ()),
    "--temperatures": ("chamber set points, degC", ()),
    "--timeout": ("seconds to wait for an answer", ("--timeout-s",)),
}


class HelpFormatter(argparse.HelpFormatter):
    """Fills prose paragraphs to the terminal; keeps indented paragraphs
    (the examples) as written."""

    def _fill_text(self, text, width, indent):
        out = []
        for para in textwrap.dedent(text).strip("\n").split("\n\n"):
            lines = para.split("\n")
            if all(line.startswith(" ") for line in lines[1:]) and (lines[0].endswith(":") or lines[0][:1] == " "):
                out.append("\n".join(indent + line for line in lines))  # a heading and its example lines
            else:
                out.append(textwrap.fill(" ".join(para.split()), width, initial_indent=indent,
                                         subsequent_indent=indent))
        return "\n\n".join(out)


def command(sub, name: str, summary: str, description: str, examples, **kw) -> argparse.ArgumentParser:
    """A subcommand with its one-line summary (`inclino --help`), one
    paragraph of description and its examples (`inclino NAME --help`)."""
    if isinstance(examples, str):
        examples = [examples]
    epilog = "example" + ("s" if len(examples) > 1 else "") + ":\n" + "\n".join("  " + e for e in examples)
    return sub.add_parser(name, help=summary, description=description, epilog=epilog,
                          formatter_class=HelpFormatter, **kw)


class Deprecated(argparse.Action):
    """An old spelling kept working: hidden from --help, and when used it
    prints `inclino: note: OLD is deprecated; use NEW` on stderr and stores
    its value where the new option does (or calls `apply(namespace,
    value)`)."""

    def __init__(self, option_strings, dest, use: str = "", apply=None, **kw):
        kw["help"] = argparse.SUPPRESS
        kw.setdefault("default", argparse.SUPPRESS)
        self.use, self.apply = use, apply
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        if not self.option_strings and (values is None or values is argparse.SUPPRESS):
            return  # an optional positional left out
        note(f"{option_string or self.metavar or self.dest} is deprecated; use {self.use}")
        if self.nargs == 0:
            values = self.const
        if self.apply is not None:
            self.apply(namespace, values)
        else:
            setattr(namespace, self.dest, values)


def note(text: str) -> None:
    print(f"inclino: note: {text}", file=sys.stderr)


def deprecated(p, old: str, new: str, dest: str | None = None, flag: bool = False, apply=None, **kw):
    """`old` as a hidden alias of `new` (same dest unless given)."""
    if old.startswith("-"):
        dest = dest or new.lstrip("-").replace("-", "_")
        if flag:
            kw.update(nargs=0, const=True)
        return p.add_argument(old, action=Deprecated, dest=dest, use=new, apply=apply, **kw)
    # a positional: stored through apply (a positional cannot share a dest)
    dest = dest or new.lstrip("-").replace("-", "_")
    return p.add_argument(old, action=Deprecated, nargs="?", use=new,
                          apply=apply or (lambda ns, v: setattr(ns, dest, v)), **kw)


def add_port(p, timeout: float = 1.0, required: bool = True, what: str = "the probe") -> None:
    """--port, --baud, --timeout: every command that opens the link.  The
    port is a declared input (no output may name it, inclino.cli.paths);
    a required port defaults to $INCLINO_PORT (docs/cli.md, "The port")."""
    import os

    from inclino.cli.paths import PORT_ENV, Input

    env = (os.environ.get(PORT_ENV) or None) if required else None
    p.add_argument("--port", action=Input, required=required and env is None, default=env, metavar="PORT",
                   help=f"serial port of {what}: a name (/dev/ttyUSB0, COM3), a pyserial URL, or the path "
                        "`inclino emulate` prints" + (f" (default: ${PORT_ENV})" if required else ""))
    p.add_argument("--baud", type=int, default=115200, help="serial speed, bits/s (default %(default)s)")
    p.add_argument("--timeout", type=float, default=timeout,
                   help="seconds to wait for an answer (default %(default)g)")


def add_json(p, what: str = "print the result as one JSON object") -> None:
    p.add_argument("--json", action="store_true", help=what)


def add_cal(p, help: str, positional_alias: bool = False, **kw) -> None:
    """--cal CAL.json; `positional_alias`: the command once took it as its
    positional argument, still accepted."""
    if positional_alias:  # required, checked by the command (require()): argparse's would refuse the old form
        help = "required: " + help
    from inclino.cli.paths import Input

    p.add_argument("--cal", metavar="CAL.json", action=Input, help=help, **kw)
    if positional_alias:
        deprecated(p, "cal_file", "--cal CAL.json", dest="cal", metavar="CAL.json")


def require(args, dest: str, option: str, what: str) -> None:
    """A required option that also has a deprecated spelling (argparse's
    required= would refuse the old form): exit 2 when neither was given."""
    from inclino.errors import DataError

    if getattr(args, dest, None) in (None, ""):
        raise DataError(f"{option} is required ({what})")


def add_output(p, help: str, required: bool = True, metavar: str = "FILE", **kw) -> None:
    """-o/--output: a declared output (inclino.cli.paths), a folder when
    its metavar is DIR."""
    from inclino.cli.paths import Output, OutputDir

    p.add_argument("-o", "--output", required=required, metavar=metavar, help=help,
                   action=OutputDir if metavar == "DIR" else Output, **kw)


def add_plot(p, help: str) -> None:
    from inclino.cli.paths import OutputPlot

    p.add_argument("--plot", metavar="DIR", action=OutputPlot, help=help)


def plot_target(value: str, default_name: str):
    """(folder, file name) of a --plot value: a folder, where the figure is
    written as `default_name`; a value ending in .png is the older meaning
    (the figure's own file), still accepted with a note."""
    import os

    if value.lower().endswith(".png"):
        note(f"--plot {value}: a PNG file name is deprecated; --plot takes a folder (the figure is written "
             f"there as {default_name})")
        return os.path.dirname(value) or ".", os.path.basename(value)
    return value, default_name
