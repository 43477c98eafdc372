"""Standards the survey commands follow: the geomagnetic models' validity
windows (exit 2 with the model's range, a library's printout never on
standard output), grid convergence on the CRS's own datum, and LAS depth
units read or refused."""
import contextlib
import io
import json
import math

import numpy as np
import pytest

from inclino import cli
from inclino.survey import geomag, wellpath as wp
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def test_a_date_outside_the_main_field_model_is_refused_with_its_range(capsys):
    first, last = geomag.igrf_range()
    assert (first.year, last.year, last.month, last.day) == (1900, 2030, 1, 1)
    for date in ("2030-06-01", "2031-01-01", "1899-12-31"):
        rc, out, err = run(capsys, "reffield", "--lat", 52, "--lon", 4, "--date", date, "--json")
        assert rc == 2 and out == "" and "1900-01-01 to 2030-01-01" in err and err.count("\n") == 1, err
    pytest.importorskip("pygeomag")
    rc, out, err = run(capsys, "reffield", "--lat", 52, "--lon", 4, "--date", "2030-02-01", "--model", "wmm")
    assert rc == 2 and out == "" and "2015-01-01 to 2029-12-31" in err
    rc, out, err = run(capsys, "reffield", "--lat", 52, "--lon", 4, "--date", "2029-12-31", "--json")
    assert rc == 0 and json.loads(out)["date"] == "2029-12-31"


def test_what_a_library_prints_never_reaches_standard_output(capsys, monkeypatch, tmp_path):
    """ppigrf prints its warnings; they go to stderr, so `reffield --json`
    and `trajectory -o -` stay parseable."""
    import ppigrf

    real = ppigrf.igrf

    def chatty(*a, **k):
        print("Warning: You provided date(s) not covered by coefficient file")
        return real(*a, **k)

    monkeypatch.setattr(ppigrf, "igrf", chatty)
    rc, out, err = run(capsys, "reffield", "--lat", 52, "--lon", 4, "--date", "2026-06-01", "--json")
    assert rc == 0 and json.loads(out)["lat_deg"] == 52 and "Warning" in err
    p = tmp_path / "s.csv"
    p.write_text("md_m,inc_deg,azi_deg\n0,0,0\n30,3,40\n60,6,40\n")
    rc, out, err = run(capsys, "trajectory", p, "--lat", 52, "--lon", 4, "--date", "2026-06-01", "-o", "-")
    assert rc == 0 and "Warning" in err and "Warning" not in out
    assert [ln for ln in out.splitlines() if not ln.startswith("#")][0].startswith("md_m,")


@pytest.mark.parametrize("epsg,lat,lon", [(27700, 52.0, -1.5), (23031, 52.5, 4.5), (32631, 52.0, 4.0)])
def test_grid_convergence_is_taken_on_the_crs_own_datum(epsg, lat, lon):
    """OSGB36 (27700) and ED50 (23031) lie ~100 m from WGS 84, and their
    ellipsoids' normals (so their meridians) differ by ~0.001 deg: the
    convergence is the grid bearing of the CRS's own meridian through the
    place (the place carried into its datum first), not the projection's
    factor at the WGS 84 latitude and longitude read as the CRS's own (the
    defect: 0.001-0.0015 deg, 5 cm at 2.3 km)."""
    import pyproj

    lat += RNG.uniform(-0.5, 0.5)
    lon += RNG.uniform(-0.5, 0.5)
    gamma, k, x, y = geomag.grid(lat, lon, epsg)
    crs = pyproj.CRS.from_epsg(epsg)
    lo, la = pyproj.Transformer.from_crs("EPSG:4326", crs.geodetic_crs, always_xy=True).transform(lon, lat)
    tr = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
    x0, y0 = tr.transform(lo, la - 1e-4)
    x1, y1 = tr.transform(lo, la + 1e-4)
    assert gamma == pytest.approx(-math.degrees(math.atan2(x1 - x0, y1 - y0)), abs=2e-6)
    naive = pyproj.Proj(crs).get_factors(lon, lat).meridian_convergence
    if epsg != 32631:  # another datum: its coordinates are not WGS 84's
        assert abs(naive - gamma) > 5e-4
    else:
        assert naive == pytest.approx(gamma, abs=1e-9)


def test_las_depth_units_are_read_or_refused(tmp_path, capsys):
    import lasio

    md_m = np.array([0.0, 30.48, 60.96, 91.44])
    for unit, factor in (("M", 1.0), ("FT", 0.3048), ("F", 0.3048), ("USFT", 1200 / 3937), ("CM", 0.01)):
        las = lasio.LASFile()
        las.append_curve("DEPT", md_m / factor, unit=unit)
        las.append_curve("INC", np.array([0.0, 5, 10, 15]), unit="deg")
        las.append_curve("AZI", np.array([20.0, 20, 20, 20]), unit="deg")
        p = tmp_path / f"s-{unit}.las"
        las.write(str(p), version=2.0, fmt="%.10f")
        sv = wp.read_survey(str(p))
        assert np.allclose(sv.md_m, md_m, atol=1e-6), unit
    assert not np.isclose(0.3048, 1200 / 3937, rtol=1e-7)  # the two feet differ (2 ppm): 6 mm at 3 km
    good = (tmp_path / "s-M.las").read_text()
    assert good.count("DEPT.M ") == 1
    for unit in ("KM", "furlong", ""):  # written by hand: lasio fills a blank index unit in itself
        p = tmp_path / "bad.las"
        p.write_text(good.replace("DEPT.M ", f"DEPT.{unit} "))
        rc, out, err = run(capsys, "trajectory", p, "--declination", 0, "-o", tmp_path / "o.csv")
        assert rc == 2 and ("depth unit" in err or "no unit" in err), (unit, err)


def test_the_field_example_files_read_back(root):
    """docs/survey-field: the in-run and out-run the emulated probe logged
    read as such, their LAS files conform, and they carry who and when."""
    from lasconform import conformance

    d = root / "docs" / "survey-field"
    for name, run in (("inrun", "in-run"), ("outrun", "out-run")):
        for ext in ("csv", "las"):
            sv = wp.read_survey(str(d / f"{name}.{ext}"))
            assert sv.meta["run"] == run and len(sv) == 21 and "utc" in sv.extra
            assert sv.meta["probe_serial"] and sv.meta["calibration_crc"]
        assert conformance((d / f"{name}.las").read_text()) == []
    assert conformance((d / "trajectory-complete.las").read_text()) == []


def test_a_las_file_of_another_tool_names_the_curves_it_lacks_and_has(tmp_path, capsys):
    """Another tool's LAS file (DEVI, HAZI) was refused as a CSV is:
    `missing column inc_deg, azi_deg (a survey listing needs md_m, ...)`,
    names no LAS file has.  The line names the curves read (INC; AZI or
    AZIM, magnetic) and the file's own."""
    import lasio

    las = lasio.LASFile()
    las.append_curve("DEPT", np.array([0.0, 100, 200]), unit="F")
    las.append_curve("DEVI", np.array([0.0, 5, 10]), unit="deg")
    las.append_curve("HAZI", np.array([45.0, 45, 45]), unit="deg")
    p = tmp_path / "other.las"
    las.write(str(p), version=2.0)
    rc, out, err = run(capsys, "trajectory", p, "--declination", 0, "-o", tmp_path / "o.csv")
    assert rc == 2 and err.count("\n") == 1, err
    assert "INC" in err and "AZIM" in err and "DEVI" in err and "HAZI" in err and "md_m" not in err, err


def test_a_listing_with_depth_in_feet_is_refused_with_the_fix(tmp_path, capsys):
    """A CSV listing whose depth column is in feet (md_ft) was refused as
    missing md_m, without a word about the column it has or what to do."""
    p = tmp_path / "ft.csv"
    p.write_text("md_ft,inc_deg,azi_deg\n0,0,0\n100,10,10\n200,20,10\n")
    rc, out, err = run(capsys, "trajectory", p, "--declination", 0, "-o", tmp_path / "o.csv")
    assert rc == 2 and err.count("\n") == 1, err
    assert "md_ft" in err and "0.3048" in err and "DEPT.FT" in err, err
