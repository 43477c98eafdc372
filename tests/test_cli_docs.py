"""docs/cli.md documents every command and every option that `--help` lists."""
import argparse
import re

from inclino.cli import build_parser


def _subcommands():
    p = build_parser()
    sub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


def test_every_flag_in_every_help_appears_in_cli_md(root):
    doc = (root / "docs" / "cli.md").read_text(encoding="utf-8")
    missing = []
    for name, sp in _subcommands().items():
        help_text = sp.format_help()
        if not re.search(rf"`{re.escape(name)}\b", doc):
            missing.append(name)
        for action in sp._actions:
            for opt in action.option_strings:
                if opt in ("-h", "--help"):
                    continue
                assert opt in help_text  # what --help prints
                if not re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", doc):
                    missing.append(f"{name} {opt}")
    assert not missing, f"in --help but not in docs/cli.md: {', '.join(missing)}"
