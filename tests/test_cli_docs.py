"""docs/cli.md's per-command sections are what the parsers write
(`python -m inclino.cli.docgen`), and its hand-written command table names
every command."""
import argparse
import re

from inclino.cli import build_parser, docgen
from inclino.errors import DataError


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


def test_the_documents_command_lines_use_todays_spellings(root):
    """Every `inclino ...` line of a code block in the documents (not a
    synopsis with [optional] parts) parses, with no deprecation note: the
    documents teach the current names."""
    import contextlib
    import io
    import shlex

    files = sorted((root / "docs").glob("*.md")) + [root / "README.md", root / "CONTRIBUTING.md"]
    bad, seen = [], 0
    for f in files:
        for block in re.findall(r"```[a-z]*\n(.*?)```", f.read_text(encoding="utf-8"), re.S):
            for line in block.splitlines():
                cmd = re.sub(r"\s+#.*$", "", re.sub(r"^\$ ", "", line.strip()))
                cmd = re.sub(r"\s+>>?\s*\S+$", "", cmd)  # a shell redirection
                if not cmd.startswith("inclino ") or cmd.startswith("inclino emulator:") or \
                        any(c in cmd for c in "[]|…") or "..." in cmd:
                    continue
                err = io.StringIO()
                try:
                    with contextlib.redirect_stderr(err):
                        build_parser().parse_args(shlex.split(cmd)[1:])
                except SystemExit:
                    pass
                seen += 1
                if err.getvalue():
                    bad.append(f"{f.name}: {cmd}: {err.getvalue().strip()}")
    assert seen >= 20 and not bad, "\n".join(bad)


def test_the_documents_inline_commands_use_todays_spellings(root):
    """A command quoted in running text (`accept --cal c.json -o c.json`,
    `trajectory -o t.csv --las t.csv`) names no deprecated option either."""
    import contextlib
    import io
    import shlex

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    files = sorted((root / "docs").glob("*.md")) + [root / "README.md"]
    bad, seen = [], 0
    for f in files:
        text = re.sub(r"```.*?```", "", f.read_text(encoding="utf-8"), flags=re.S)
        for span in re.findall(r"`([^`\n]+)`", text):
            words = span.removeprefix("inclino ").split()
            if len(words) < 2 or words[0] not in sub.choices or not any(w.startswith("-") for w in words) or \
                    any(c in span for c in "[]|…") or "..." in span:  # a synopsis, not a command
                continue
            try:
                argv = shlex.split(span.removeprefix("inclino "))
            except ValueError:
                continue
            err = io.StringIO()
            try:
                with contextlib.redirect_stderr(err):
                    build_parser().parse_args(argv)
            except (SystemExit, DataError):  # a fragment: placeholders, options left out
                pass
            seen += 1
            if "is deprecated" in err.getvalue():
                bad.append(f"{f.name}: `{span}`: {err.getvalue().strip().splitlines()[0]}")
    assert seen >= 50 and not bad, "\n".join(bad)


def test_the_demo_takes_as_long_in_the_readme_as_in_its_help(root):
    """The README and `inclino demo --help` give one duration."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    helps = re.findall(r"in about (\d+) s\b", sub.choices["demo"].description)
    readme = re.findall(r"in about (\d+) s\b", (root / "README.md").read_text(encoding="utf-8"))
    assert len(helps) == 1 and readme == helps, (readme, helps)
