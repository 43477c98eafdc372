"""docs/cli.md's per-command sections are what the parsers write
(`python -m inclino.cli.docgen`), and its hand-written command table names
every command."""
import argparse
import re

from inclino.cli import build_parser, docgen


def test_cli_md_is_what_the_generator_writes(root):
    text = (root / "docs" / "cli.md").read_text(encoding="utf-8")
    assert docgen.render(text) == text, "docs/cli.md is out of date: run python -m inclino.cli.docgen"


def test_the_check_fails_on_a_stale_file(root, tmp_path, capsys):
    text = (root / "docs" / "cli.md").read_text(encoding="utf-8")
    stale = tmp_path / "cli.md"
    stale.write_text(text.replace("- `--surveys`: surveys to check bit for bit", "- `--surveys`: surveys"))
    assert stale.read_text() != text
    assert docgen.main(["--path", str(stale), "--check"]) == 1
    assert docgen.main(["--path", str(stale)]) == 0 and stale.read_text() == text
    assert docgen.main(["--path", str(stale), "--check"]) == 0


def test_every_option_has_its_line_and_every_command_its_row(root):
    text = (root / "docs" / "cli.md").read_text(encoding="utf-8")
    hand, generated = text.split(docgen.BEGIN)
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, sp in sub.choices.items():
        assert re.search(rf"^\| `{re.escape(name)}\b", hand, re.M), f"no row for {name} in the command table"
        section = generated.split(f"\n### {name}\n")[1].split("\n### ")[0]
        for a in sp._actions:
            if a.help != argparse.SUPPRESS and a.option_strings and a.option_strings[0] != "-h":
                assert f"- `{a.option_strings[0]}`" in section, (name, a.option_strings)
