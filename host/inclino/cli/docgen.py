"""docs/cli.md's per-command sections, written from the argparse
definitions: `python -m inclino.cli.docgen` rewrites the part of
docs/cli.md between the markers; `--check` exits 1 when the file differs
from what it would write (tests/test_cli_docs.py runs it).  The rest of the
file (exit statuses, output files, progress, option rules) is written by
hand and left as it is."""
from __future__ import annotations

import argparse
import os
import sys

BEGIN = "<!-- BEGIN GENERATED: `python -m inclino.cli.docgen` writes this part from the parsers; edit them -->"
END = "<!-- END GENERATED -->"
WIDTH = 100  # the usage lines' width: fixed, so the file does not depend on the terminal


def _entry_points():
    """(title, parser) of every command documented: the `inclino`
    subcommands in `inclino --help`'s order, then the module entry points."""
    from inclino.cli import bench_diagnose, bench_temperature, build_parser, s08

    root = build_parser()
    sub = next(a for a in root._actions if isinstance(a, argparse._SubParsersAction))
    out = [(name, p) for name, p in sub.choices.items()]
    s = s08.build_parser()
    ssub = next(a for a in s._actions if isinstance(a, argparse._SubParsersAction))
    out += [(f"python -m inclino.cli.s08 {n}", p) for n, p in ssub.choices.items()]
    out += [("python -m inclino.cli.bench_diagnose", bench_diagnose.build_parser()),
            ("python -m inclino.cli.bench_temperature", bench_temperature.build_parser())]
    return out


def _usage(p) -> str:
    f = p.formatter_class(prog=p.prog, width=WIDTH)
    f.add_usage(p.usage, p._actions, p._mutually_exclusive_groups, prefix="")
    return f.format_help().strip()


def _option_line(p, a) -> str:
    from inclino.cli.options import Deprecated

    names = ", ".join(f"`{o}`" for o in a.option_strings) or f"`{a.metavar or a.dest}`"
    f = p._get_formatter()
    text = " ".join(f._expand_help(a).split()) if a.help else ""
    sep = " \\| "  # a table's bar escaped, as the hand-written part writes it
    choices = f" ({sep.join(map(str, a.choices))})" if a.choices and not isinstance(a, Deprecated) else ""
    req = " (required)" if a.required and a.option_strings else ""
    return f"- {names}{choices}{req}: {text}"


def section(title: str, p) -> str:
    from inclino.cli.options import Deprecated

    lines = [f"### {title}", "", " ".join((p.description or "").split()), "", "```", _usage(p), "```", ""]
    old = []
    for a in p._actions:
        if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        if isinstance(a, Deprecated):
            old.append(f"`{a.option_strings[0] if a.option_strings else a.metavar}` (use `{a.use}`)")
            continue
        lines.append(_option_line(p, a))
    lines += ["", "Example" + ("s" if p.epilog.count("\n") > 1 else "") + ":", "", "```sh"]
    lines += [e.strip() for e in p.epilog.splitlines()[1:]]
    lines += ["```"]
    if old:
        lines += ["", "Old spellings, still accepted with a note on stderr: " + ", ".join(old) + "."]
    return "\n".join(lines)


def generated() -> str:
    return "\n\n".join(section(t, p) for t, p in _entry_points())


def render(text: str) -> str:
    """The whole file with its generated part replaced."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise ValueError(f"docs/cli.md must hold the markers {BEGIN!r} and {END!r} once each, in that order")
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    return f"{head}{BEGIN}\n\n{generated()}\n\n{END}{tail}"


def default_path() -> str:
    here = os.path.dirname(os.path.abspath(__file__))
    return os.path.normpath(os.path.join(here, "..", "..", "..", "docs", "cli.md"))


def main(argv=None) -> int:
    from inclino.cli.options import HelpFormatter

    ap = argparse.ArgumentParser(prog="python -m inclino.cli.docgen", formatter_class=HelpFormatter,
                                 description="Write docs/cli.md's per-command sections from the parsers, or check "
                                             "that the file holds what they would write.",
                                 epilog="examples:\n  python -m inclino.cli.docgen\n"
                                        "  python -m inclino.cli.docgen --check")
    ap.add_argument("--path", default=default_path(), help="the file (default: the checkout's docs/cli.md)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 when the file is out of date")
    a = ap.parse_args(argv)
    with open(a.path, encoding="utf-8") as f:
        text = f.read()
    new = render(text)
    if a.check:
        if new != text:
            print(f"{a.path} is out of date: run python -m inclino.cli.docgen", file=sys.stderr)
            return 1
        return 0
    if new != text:
        from inclino.formats import safeio

        safeio.write_output(a.path, new)
        print(f"wrote {a.path}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
