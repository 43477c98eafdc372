"""The parser walk: every command of `inclino` (and of the module entry
points) follows the option rules of CONTRIBUTING.md ("Options"): help text
on every option, its default shown, a description and an example on every
command, one name per quantity (the old spellings only as hidden aliases
that still work and say their new name)."""
import argparse
import io
import re
from contextlib import redirect_stderr

import pytest

from inclino.cli import bench_diagnose, bench_temperature, build_parser, main, s08
from inclino.cli.options import CANONICAL, Deprecated


def _walk(parser, path):
    """(command path, parser) of every parser, through subparsers."""
    yield path, parser
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sp in a.choices.items():
                yield from _walk(sp, path + (name,))


def _parsers():
    roots = [(("inclino",), build_parser()), (("python -m inclino.cli.s08",), s08.build_parser()),
             (("python -m inclino.cli.bench_diagnose",), bench_diagnose.build_parser()),
             (("python -m inclino.cli.bench_temperature",), bench_temperature.build_parser())]
    out = []
    for path, p in roots:
        out += list(_walk(p, path))
    return out


PARSERS = _parsers()
COMMANDS = [(path, p) for path, p in PARSERS if not any(isinstance(a, argparse._SubParsersAction)
                                                         for a in p._actions)]


def _options(parser):
    for a in parser._actions:
        if isinstance(a, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)):
            continue
        yield a


def _name(path, a):
    return " ".join(path) + " " + ("/".join(a.option_strings) or a.dest)


def test_the_walk_reaches_every_command():
    names = {" ".join(path[1:]) for path, _ in COMMANDS if path[0] == "inclino"}
    assert {"demo", "identify", "survey", "download", "verify", "flash", "acquire", "accept", "calibrate",
            "diagnose", "reffield", "trajectory", "emulate", "bench"} <= names
    assert len(COMMANDS) >= 22  # the inclino commands and the module entry points' commands


def test_every_option_has_help_text():
    missing = [_name(path, a) for path, p in PARSERS for a in _options(p)
               if not isinstance(a, Deprecated) and not (a.help and a.help.strip())]
    assert not missing, "options without help text: " + ", ".join(missing)


def _shown(default) -> set:
    if isinstance(default, float):
        return {f"{default:g}", repr(default), str(default)}
    if isinstance(default, (list, tuple)):
        return {",".join(map(str, default)), " ".join(map(str, default))}
    return {str(default)}


def test_every_default_is_shown_in_the_help():
    missing = []
    for path, p in PARSERS:
        fmt = p._get_formatter()
        for a in _options(p):
            d = a.default
            if isinstance(a, Deprecated) or d is None or d is False or d is argparse.SUPPRESS or a.required:
                continue
            text = fmt._expand_help(a) if a.help else ""
            m = re.search(r"default[:\s]", text)
            if not m or not any(s in text[m.start():] for s in _shown(d)):
                missing.append(f"{_name(path, a)} (default {d!r}): {text!r}")
    assert not missing, "defaults not shown:\n" + "\n".join(missing)


def test_every_command_has_a_description_and_an_example():
    bad = []
    for path, p in COMMANDS:
        desc = (p.description or "").strip()
        if len(desc.split()) < 12:
            bad.append(f"{' '.join(path)}: description {desc!r}")
        prog = " ".join(path)
        if not p.epilog or not re.search(r"^examples?:\n", p.epilog) or prog not in p.epilog:
            bad.append(f"{prog}: no example (an epilog 'example:' with a line starting {prog!r})")
    assert not bad, "\n".join(bad)


def test_no_quantity_has_two_names():
    """A replaced spelling only as a hidden alias; output JSON only as --json
    (no --format json); the plot target always a folder; a time option in
    seconds or with its unit in its name; the calibration file only as
    --cal (a positional CAL.json only as a hidden alias)."""
    forbidden = {old: new for new, (_, olds) in CANONICAL.items() for old in olds}
    bad = []
    for path, p in PARSERS:
        for a in _options(p):
            name = _name(path, a)
            hidden = isinstance(a, Deprecated) and a.help is argparse.SUPPRESS
            for o in a.option_strings:
                if o in forbidden and not hidden:
                    bad.append(f"{name}: {o} is spelled {forbidden[o]}")
                if o in CANONICAL and hidden:
                    bad.append(f"{name}: the canonical {o} is hidden")
            if hidden:
                continue
            if a.choices and {"json", "csv", "table"} & set(map(str, a.choices)):
                bad.append(f"{name}: an output form is a flag (--json, --csv), not a choice")
            if "--plot" in a.option_strings and a.metavar != "DIR":
                bad.append(f"{name}: --plot is a folder (metavar DIR)")
            if "--output" in a.option_strings and "-o" not in a.option_strings:
                bad.append(f"{name}: the output is -o/--output")
            help_ = (a.help or "").lower()
            first = help_.split(",")[0].split("(")[0]
            for unit, suffix in (("minutes", "-min"), ("milliseconds", "-ms")):
                if unit in first and a.option_strings and not any(o.endswith(suffix) for o in a.option_strings):
                    bad.append(f"{name}: a time in {unit} carries {suffix} in its name")
            if not a.option_strings and a.dest in ("cal", "calibration"):
                bad.append(f"{name}: the calibration file is --cal CAL.json")
    assert not bad, "\n".join(bad)


def _deprecated_aliases():
    for path, p in PARSERS:
        for a in p._actions:
            if isinstance(a, Deprecated):
                yield path, p, a


def test_every_old_spelling_still_works_and_says_its_new_name():
    seen = 0
    for path, p, a in _deprecated_aliases():
        ns = argparse.Namespace()
        value = [] if a.nargs == 0 else (a.choices[-1] if a.choices else ("7" if a.type is None else a.type("7")))
        err = io.StringIO()
        with redirect_stderr(err):
            a(p, ns, value, a.option_strings[0] if a.option_strings else None)
        lines = err.getvalue().splitlines()
        assert len(lines) == 1 and lines[0].startswith("inclino: note: ") and "deprecated; use" in lines[0], lines
        assert vars(ns), f"{_name(path, a)} stored nothing"
        seen += 1
    assert seen >= 10


@pytest.mark.parametrize("old, new, dest", [
    (["reffield", "--declination", "1", "--total", "48000"], ["reffield", "--declination", "1", "--field", "48000"],
     "field"),
    (["calibrate", "r.csv", "-o", "c.json", "--temperature", "on"],
     ["calibrate", "r.csv", "-o", "c.json", "--temperature-terms", "on"], "temperature_terms"),
    (["demo", "--out", "d"], ["demo", "-o", "d"], "output"),
    (["demo", "--temperature"], ["demo", "--chamber"], "chamber"),
    (["survey", "--port", "p", "--period", "50"], ["survey", "--port", "p", "--period-ms", "50"], "period_ms"),
    (["survey", "--port", "p", "--format", "csv"], ["survey", "--port", "p", "--csv"], "csv"),
    (["download", "--port", "p", "c.json"], ["download", "--port", "p", "--cal", "c.json"], "cal"),
    (["verify", "--port", "p", "c.json"], ["verify", "--port", "p", "--cal", "c.json"], "cal"),
    (["toolmodel", "c.json", "-o", "t.json"], ["toolmodel", "--cal", "c.json", "-o", "t.json"], "cal"),
    (["accept", "--port", "p", "--save", "a.json"], ["accept", "--port", "p", "-o", "a.json"], "output"),
    (["acquire", "--port", "p", "--procedure", "temperature", "-o", "r.csv", "--interval", "3", "--soak-window",
      "5", "--max-soak", "60"],
     ["acquire", "--port", "p", "--procedure", "temperature", "-o", "r.csv", "--interval-min", "3",
      "--soak-window-min", "5", "--max-soak-min", "60"], "max_soak_min"),
])
def test_an_old_spelling_parses_as_the_new_one(old, new, dest, capsys):
    p = build_parser()
    b = p.parse_args(new)
    assert capsys.readouterr().err == ""
    a = p.parse_args(old)
    err = capsys.readouterr().err.splitlines()
    assert vars(a) == vars(b) and getattr(b, dest) not in (None, False)
    olds = [w for w in old if w.startswith("-") and w not in new] or ["CAL.json"]
    assert len(err) == len(olds) and all(line.startswith("inclino: note: ") for line in err), err


def test_a_required_calibration_left_out_is_one_line_and_exit_2(capsys):
    rc = main(["verify", "--port", "/nonexistent"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == ["inclino: error: --cal CAL.json is required (the calibration to check against)"]


def test_no_hidden_alias_shows_in_help():
    for path, p, a in _deprecated_aliases():
        words = set(re.findall(r"(?<![\w-])--?[\w-]+", p.format_help()))
        for o in a.option_strings:
            assert o not in words, (path, o)
        if not a.option_strings:
            assert a.dest not in p.format_help(), (path, a.dest)
            assert len(re.findall(re.escape(a.metavar), p.format_usage())) == 1, (path, a.dest)  # --cal's only
