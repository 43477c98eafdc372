"""The files a command reads and writes, declared where its options are.

Every option or argument that names a file is declared with one of these
argparse actions:

    p.add_argument("-o", "--output", action=Output, help=...)      # a file written
    p.add_argument("--plot", action=OutputDir, help=...)            # a folder files are written into
    p.add_argument("--cal", action=Input, help=...)                 # a file (or port) read

inclino.cli.options declares the common ones (add_port, add_cal,
add_output, add_plot) with these actions.
`inclino.cli.main` collects them from the chosen command's parser and runs
the command inside `safeio.command_files(inputs, outputs)`: before any work,
each output is refused (exit 2) when it is one of the inputs (the same file,
also through a hard or symbolic link) or names the same file as another
output; during the command, every file written -- each figure written into
an output folder included -- goes through safeio's output rule, which checks
it again against every input and every file already written.
tests/test_cli_paths.py walks every command's parser and fails for a
path-like option declared without these actions.

This module imports nothing heavy: building the parser stays cheap.
"""
from __future__ import annotations

import argparse

PORT_ENV = "INCLINO_PORT"


class _PathAction(argparse.Action):
    role = ""
    kind = "file"

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)


class Input(_PathAction):
    """A file (or serial port) the command reads."""

    role = "input"


class Output(_PathAction):
    """A file the command writes ('-': standard output)."""

    role = "output"


class OutputDir(_PathAction):
    """A folder the command writes files into (created when missing)."""

    role = "output"
    kind = "dir"


class OutputPlot(_PathAction):
    """--plot: a folder figures are written into (a value ending in .png:
    the older meaning, that figure's own file; options.plot_target)."""

    role = "output"

    @staticmethod
    def kind_of(value: str) -> str:
        return "file" if str(value).lower().endswith(".png") else "dir"


def _values(v):
    if v is None:
        return []
    if isinstance(v, (list, tuple)):
        return [str(x) for x in v if x is not None]
    return [str(v)]


def declared(parser: argparse.ArgumentParser, args) -> tuple[list, list]:
    """(inputs, outputs) of a parsed command line: inputs as paths, outputs
    as (path, kind, option name) with kind 'file' or 'dir'."""
    inputs, outputs = [], []
    for a in parser._actions:
        if not isinstance(a, _PathAction):
            continue
        name = a.option_strings[-1] if a.option_strings else a.dest
        for v in _values(getattr(args, a.dest, None)):
            if a.role == "input":
                inputs.append(v)
            else:
                kind = a.kind_of(v) if hasattr(a, "kind_of") else a.kind
                outputs.append((v, kind, name))
    return inputs, outputs


def command_parser(parser: argparse.ArgumentParser, args) -> argparse.ArgumentParser:
    """The sub-parser of the command `args` was parsed for (or the parser)."""
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            name = getattr(args, a.dest, None)
            if name in a.choices:
                return command_parser(a.choices[name], args)
    return parser
