"""--ref REF.json with the other reference options: the grid is the site's
and the projection's, so --grid adds it to a reference file; a position,
date or field value the file already holds, given again, is refused with one
line (exit 2) in every survey command; a hand-edited file whose grid has no
easting/northing is refused, not a traceback. And the messages name today's
options, never a deprecated spelling."""
import argparse
import json
import re

import numpy as np
import pytest

from inclino import cli
from inclino.survey import geomag, wellpath as wp

SITE = ["--lat", 52, "--lon", 4, "--date", "2026-06-01"]


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def one_error_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("inclino: error: ") and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def site(tmp_path, capsys):
    """ref.json of the site (no grid) and a short in-run listing."""
    ref = tmp_path / "ref.json"
    rc, _, err = run(capsys, "reffield", *SITE, "-o", ref)
    assert rc == 0, err
    s = tmp_path / "s.csv"
    md = np.arange(0, 301, 30.0)
    with open(s, "w") as f:
        f.write("md_m,inc_deg,azi_deg\n")
        for m in md:
            f.write(f"{m:g},{min(m / 6, 40):g},100\n")
    return ref, s


def test_grid_with_a_reference_file_is_the_grid_of_its_site(site, tmp_path, capsys):
    ref, s = site
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    rc, out_a, err = run(capsys, "trajectory", s, "--ref", ref, "--grid", 32631, "-o", a)
    assert rc == 0, err
    rc, out_b, err = run(capsys, "trajectory", s, *SITE, "--grid", 32631, "-o", b)
    assert rc == 0, err
    assert a.read_text() == b.read_text() and out_a == out_b
    rows = wp.read_trajectory(str(a))
    assert "azi_grid_deg" in rows[0] and "northing_m" in rows[0]
    assert "grid convergence 0.788 deg (EPSG 32631)" in out_a
    # reffield --ref --grid: the file's field with the grid, as reffield --grid prints it
    rc, t1, _ = run(capsys, "reffield", "--ref", ref, "--grid", 32631)
    rc2, t2, _ = run(capsys, "reffield", *SITE, "--grid", 32631)
    assert rc == rc2 == 0 and t1 == t2 and "grid_epsg        32631" in t1
    # the same grid again is no conflict; a file with the grid reads as it was written
    g = tmp_path / "g.json"
    rc, _, err = run(capsys, "reffield", "--ref", ref, "--grid", 32631, "-o", g)
    assert rc == 0, err
    rc, out, err = run(capsys, "trajectory", s, "--ref", g, "--grid", 32631, "-o", tmp_path / "c.csv")
    assert rc == 0 and (tmp_path / "c.csv").read_text() == a.read_text(), err


def test_grid_with_a_reference_file_it_cannot_apply_to(site, tmp_path, capsys):
    ref, s = site
    d = tmp_path / "decl.json"
    rc, _, err = run(capsys, "reffield", "--declination", 2, "-o", d)
    assert rc == 0, err
    rc, out, err = run(capsys, "trajectory", s, "--ref", d, "--grid", 32631, "-o", tmp_path / "t.csv")
    assert rc == 2 and "needs the wellhead position" in one_error_line(err)
    g = tmp_path / "g.json"
    rc, _, err = run(capsys, "reffield", *SITE, "--grid", 32631, "-o", g)
    rc, out, err = run(capsys, "trajectory", s, "--ref", g, "--grid", 25831, "-o", tmp_path / "t.csv")
    assert rc == 2 and "whose grid is EPSG 32631" in one_error_line(err)
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("opt, value", [("--declination", 10), ("--dip", 60), ("--field", 50000),
                                        ("--gravity", 1.0), ("--lat", 50), ("--lon", 3), ("--alt", 0),
                                        ("--date", "2026-01-01"), ("--model", "igrf")])
def test_a_value_the_reference_file_holds_given_again_is_refused(site, tmp_path, capsys, opt, value):
    ref, s = site
    out_csv = tmp_path / "t.csv"
    for argv in (["trajectory", s, "-o", out_csv], ["reffield"],
                 ["compare", s, s, "--tool-model", "iscwsa-mwd-rev5"]):
        rc, out, err = run(capsys, *argv, "--ref", ref, opt, value)
        line = one_error_line(err)
        assert rc == 2 and f"{opt} with --ref {ref}" in line and "given twice" in line, (argv, err)
        assert out == "" and not out_csv.exists()
    if opt in ("--declination", "--dip", "--field", "--gravity"):  # the command that writes the reference wanted
        assert f"inclino reffield --lat 52 --lon 4 --date 2026-06-01 {opt} {value:g} -o NEW.json" in line


def test_the_refusal_also_in_toolmodel(root, site, tmp_path, capsys):
    ref, _ = site
    cal = root / "docs" / "survey-field" / "cal.json"
    rc, out, err = run(capsys, "toolmodel", "--cal", cal, "--ref", ref, "--dip", 60, "-o", tmp_path / "t.json")
    assert rc == 2 and "--dip with --ref" in one_error_line(err) and not (tmp_path / "t.json").exists()


def test_a_reference_file_with_a_grid_and_no_wellhead_coordinates(site, tmp_path, capsys):
    """Written by hand: grid_epsg without easting_m/northing_m was a TypeError
    in the trajectory's grid columns."""
    ref, s = site
    d = json.loads(ref.read_text())
    d["grid_epsg"] = 32631
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    rc, out, err = run(capsys, "trajectory", s, "--ref", bad, "-o", tmp_path / "t.csv")
    line = one_error_line(err)
    assert rc == 2 and "grid_epsg 32631 needs the wellhead's easting_m and northing_m" in line


def test_outside_the_model_the_message_names_field_not_total(capsys):
    rc, out, err = run(capsys, "reffield", "--lat", 52, "--lon", 4, "--date", "2031-01-01")
    line = one_error_line(err)
    assert rc == 2 and line.endswith("give the field with --declination, --dip, --field"), line


def _deprecated_spellings():
    from inclino.cli.options import Deprecated

    old = set()

    def walk(p):
        for a in p._actions:
            if isinstance(a, Deprecated):
                old.update(a.option_strings)
            if isinstance(a, argparse._SubParsersAction):
                for sp in a.choices.values():
                    walk(sp)
    walk(cli.build_parser())
    return old


def test_no_message_names_a_deprecated_option(root):
    """Every string in the package that names an option names today's: an
    old spelling appears only where it is declared deprecated (options.py's
    table and the deprecated() calls)."""
    old = _deprecated_spellings()
    assert {"--total", "--out", "--save", "--period"} <= old
    pat = re.compile(r"(?<![-\w])(" + "|".join(map(re.escape, sorted(old))) + r")(?![-\w])")
    bad = []
    for f in sorted((root / "host" / "inclino").rglob("*.py")):
        if f.name == "options.py" and f.parent.name == "cli":
            continue
        for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            if "deprecated(" in line:
                continue
            if pat.search(line):
                bad.append(f"{f.relative_to(root)}:{n}: {line.strip()}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("lon, zone", [(100.0, "47N (EPSG:32647)"), (10.0, "32N (EPSG:32632)")])
def test_a_grid_far_outside_its_area_of_use_is_refused_with_the_zone_there(lon, zone, capsys):
    """UTM zone 31N (0-6 deg E) at 52 N 100 E gave a convergence of 98.8 deg,
    and one zone off 5.5 deg, both exit 0; a position 0.5 deg past the zone's
    edge (UTM zones are stretched so in practice) is still read."""
    rc = cli.main(["reffield", "--lat", "52", "--lon", str(lon), "--date", "2025-01-01", "--grid", "32631"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "is for 0 to 6 deg E" in err and zone in err, err
    gamma, k, x, y = geomag.grid(52.0, 6.5, 32631)
    assert 2.0 < gamma < 3.0 and 0.9995 < k < 1.001  # (6.5 - 3) sin 52 = 2.76 deg


def test_a_dataset_separated_by_semicolons_is_told_so(tmp_path, capsys):
    p = tmp_path / "semi.csv"
    p.write_text("ax_g;ay_g;az_g\n0;0;1\n")
    rc = cli.main(["calibrate", str(p), "-o", str(tmp_path / "c.json")])
    err = capsys.readouterr().err
    assert rc == 2 and "the header is one column separated by semicolons" in err and err.count("\n") == 1, err
