"""Done-when: `compare` of two surveys of the same stations with the same
calibration passes at >= 95 % of the stations.  The emulated typical
probe, calibrated (joint) and the calibration downloaded, surveys the
stations going in (depth increasing, one file continued with --append) and
coming out (depth decreasing: an out-run), at a new toolface each time;
`compare --cal` pairs them by depth with the noise the calibration's fit
report measured.  With the noise taken as zero (what the tools assumed
before) the same pairs fail."""
import json

import numpy as np

from inclino import cli
from inclino.benchmarks import survey as sb
from inclino_emu.control import ControlClient
from inclino_emu.runner import Emulator
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)
N = 24


def run(capsys, *argv):
    rc = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def test_in_run_and_out_run_of_the_same_stations_agree(tmp_path, capsys):
    from inclino.survey import geomag

    seed = int(RNG.integers(1, 1 << 20))
    scen = sb.scenario_file(str(tmp_path / "s.toml"), geomag.normal_gravity_g(sb.LAT))
    cal = str(tmp_path / "cal.json")
    sb.calibrate(scen, cal, seed)
    md = np.sort(RNG.choice(np.arange(30.0, 1500.0, 15.0), N, replace=False))
    inc = RNG.uniform(3, 85, N)
    azi = RNG.uniform(0, 360, N)
    files = {"in": tmp_path / "in.csv", "out": tmp_path / "out.csv"}
    with Emulator(scen, seed=seed, control_port=0, realtime=False) as emu:
        ctl = ControlClient(port=emu.control_port)
        assert run(capsys, "download", "--port", emu.path, "--cal", cal, "--quiet")[0] == 0
        for run_name, order in (("in", range(N)), ("out", reversed(range(N)))):
            for n, i in enumerate(order):
                ctl.call("move", inc=float(inc[i]), azi=float(azi[i]), tf=float(RNG.uniform(0, 360)))
                # the first surveys after a move settle the filters: with one, ~1 run in 20 had two stations beyond
                # 3 sigma (d inc 0.03-0.05 deg) while the differences stay at 0.8 sigma RMS over 576 others, taken
                # for a survey read before the filters settled (30 runs of 30 pass with two)
                run(capsys, "survey", "--port", emu.path)
                run(capsys, "survey", "--port", emu.path)
                rc, out, err = run(capsys, "survey", "--port", emu.path, "--md", md[i], "-o", files[run_name],
                                   *(["--append"] if n else []))
                assert rc == 0, err
        ctl.close()
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal, "--json")
    r = json.loads(out)
    assert r["runs"] == ["in-run", "out-run"] and r["summary"]["pairs"] == N, out + err
    assert r["summary"]["passed_fraction"] >= 0.95, [s for s in r["stations"] if s["verdict"] != "PASS"]
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal)
    assert "noise per survey" in out and "fit report" in out
    # the noise taken as zero: the differences the readings' noise makes are outside the expected spread
    rc, out, err = run(capsys, "compare", files["in"], files["out"], "--cal", cal, "--acc-noise", 0, "--mag-noise", 0,
                       "--json")
    zero = json.loads(out)
    assert rc == 1 and zero["summary"]["passed_fraction"] < r["summary"]["passed_fraction"]


def _pairs_by_scan(md_a, md_b, md_tol):
    """The pairing rule written out: each station of a in order takes the
    nearest unused station of b (the first of equals) within md_tol."""
    used, pairs = set(), []
    for i, md in enumerate(md_a):
        j = int(np.argmin(np.abs(md_b - md)))
        if abs(md_b[j] - md) <= md_tol and j not in used:
            used.add(j)
            pairs.append((i, j))
    return pairs


def test_pairing_by_sorted_search_is_the_scan():
    from inclino.survey.compare import pair_stations

    for _ in range(200):
        # depths on a coarse grid: equal distances and stations wanted twice happen often
        na, nb = (int(v) for v in RNG.integers(1, 40, 2))
        md_a = np.sort(RNG.choice(np.arange(0.0, 60.0, 0.5), na, replace=False))
        md_b = np.sort(RNG.choice(np.arange(0.0, 60.0, 0.5), nb, replace=False))
        tol = float(RNG.choice([0.0, 0.25, 0.5, 1.0, 5.0]))
        ia, ib = pair_stations(md_a, md_b, tol)
        assert list(zip(ia.tolist(), ib.tolist())) == _pairs_by_scan(md_a, md_b, tol), (md_a, md_b, tol)


def test_expected_spread_in_stretches_is_the_spread_at_once():
    """A station's survey covariance is its own: the error model called on
    stretches of the survey gives what one call on the whole does."""
    from inclino.survey import compare, geomag, models

    n = 700
    md = np.cumsum(RNG.uniform(5, 30, n))
    inc = np.clip(np.cumsum(RNG.normal(0.3, 1.0, n)), 0.5, 120)
    azi = np.mod(np.cumsum(RNG.normal(0, 2, n)) + 40, 360)
    rf = geomag.ReferenceField(2.0, 60.0, 50000.0, 1.0)
    model = models.ErrorModel(models.load("iscwsa-mwd-rev5"), None, None)
    for two in (False, True):
        whole = compare.expected(model, md, inc, azi, rf, two, chunk=n)
        parts = compare.expected(model, md, inc, azi, rf, two, chunk=int(RNG.integers(2, 200)))
        assert np.allclose(whole[0], parts[0], rtol=1e-12, atol=0) and np.allclose(whole[1], parts[1], rtol=1e-12,
                                                                                   atol=0)


def test_streamed_json_is_the_text_of_to_json(tmp_path, capsys):
    """compare --json writes its result as it encodes it (a 10^5-pair result
    is never one string): the text is to_json()'s, NaN written as null."""
    import io

    from inclino.benchmarks import input as bench_input
    from inclino.survey import compare as cmp

    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    bench_input.write_listing(str(a), 300, seed=1, step_m=1.0)
    bench_input.write_listing(str(b), 300, seed=2, step_m=1.0)
    rc, out, err = run(capsys, "compare", a, b, "--tool-model", "iscwsa-mwd-rev5", "--declination", 2, "--dip", 60,
                       "--field", 50000, "--json")
    assert rc in (0, 1), err
    r = json.loads(out)
    assert r["summary"]["pairs"] == 300
    res = cmp.CompareResult(**r)
    res.stations[0]["d_azi_deg"] = float("nan")  # written as null by both
    f = io.StringIO()
    res.write_json(f)
    assert f.getvalue() == res.to_json()
    assert json.loads(f.getvalue())["stations"][0]["d_azi_deg"] is None
    f = io.StringIO()
    cmp.CompareResult(**r).write_json(f)
    assert f.getvalue() + "\n" == out


def test_a_reference_adds_no_reference_terms_to_cal_alone(tmp_path, capsys):
    """`compare --cal` alone sets the differences against the probe's terms
    (docs/survey.md); a reference given for its dip and field (a file, a
    position, user values) does not add reference-field terms unless
    `--ref-terms` asks for them.  Before, any reference added OWSG's random
    declination (DECR, DBHR: 0.1 deg and 3000 deg.nT): the expected azimuth
    difference went from ~0.026 to ~0.26 deg, ten times what the same
    probe's repeat surveys scatter, and the note pointed at a --ref-terms
    compare did not have."""
    from inclino.benchmarks import input as bench_input
    from inclino.survey import geomag

    scen = sb.scenario_file(str(tmp_path / "s.toml"), geomag.normal_gravity_g(sb.LAT))
    cal = str(tmp_path / "cal.json")
    sb.calibrate(scen, cal, int(RNG.integers(1, 1 << 20)))
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    bench_input.write_listing(str(a), 30, seed=1, step_m=30.0)
    bench_input.write_listing(str(b), 30, seed=2, step_m=30.0)
    field = ("--dip", 67.1446, "--field", 49423.5)

    def sigmas(*opts):
        rc, out, err = run(capsys, "compare", a, b, "--cal", cal, *opts, "--json")
        assert rc in (0, 1), err
        r = json.loads(out)
        return r, np.array([s["sigma_d_azi_deg"] or np.nan for s in r["stations"]])

    _, alone = sigmas(*field)
    for ref in (("--declination", 2.4324, *field), ("--lat", 52, "--lon", 4, "--date", "2026-06-01")):
        r, given = sigmas(*ref)
        assert np.allclose(given, alone, rtol=1e-3, equal_nan=True), (ref, given / alone)
        assert "reference field" not in r["summary"]["error_model"].split("terms:")[1].split(";")[0]
    r, ifr1 = sigmas("--declination", 2.4324, *field, "--ref-terms", "ifr1")
    assert "reference-field terms ifr1" in r["summary"]["error_model"]
    assert np.nanmedian(ifr1 / alone) > 2  # the random declination, where the sensor terms are small


def test_three_stations_have_the_spread_they_have_within_a_longer_survey(tmp_path, capsys):
    """welleng called on exactly three stations gives the first a zero and
    the last a negative variance: `compare` of two three-station listings
    held the first pair to |d inc| <= 0 and gave the last a NaN sigma (FAIL
    with `nan`).  A station's spread is its own: the same as within a longer
    survey."""
    from inclino.survey import compare, geomag, models

    rf = geomag.ReferenceField(2.0, 60.0, 50000.0, 1.0)
    model = models.ErrorModel(models.load("iscwsa-mwd-rev5"), None, None)
    md = np.arange(6) * 30.0
    inc = np.sort(RNG.uniform(3, 170, 6))
    azi = RNG.uniform(0, 360) + np.arange(6) * 0.5
    whole = compare.expected(model, md, inc, azi, rf)
    for n in (2, 3):
        part = compare.expected(model, md[:n], inc[:n], azi[:n], rf)
        assert np.allclose(part[0], whole[0][:n], rtol=1e-9) and np.allclose(part[1], whole[1][:n], rtol=1e-9), n
    a = tmp_path / "a.csv"
    a.write_text("md_m,inc_deg,azi_deg\n" + "".join(f"{m},{i},{z}\n" for m, i, z in zip(md[:3], inc, azi)))
    rc, out, err = run(capsys, "compare", a, a, "--tool-model", "iscwsa-mwd-rev5", "--json")
    r = json.loads(out)
    assert rc == 0 and all(s["sigma_d_inc_deg"] > 0 for s in r["stations"]), out + err


def test_azimuth_is_not_checked_near_vertical_going_up(tmp_path, capsys):
    """Near-vertical is I < 0.5 or I > 179.5 deg (docs/conventions.md, the
    ATT_F_NEAR_VERTICAL flag): compare checked the azimuth of a pair at
    179.9 deg, where it is undefined, and failed two surveys of an upward
    hole whose azimuths differ as undefined azimuths do."""
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("md_m,inc_deg,azi_deg\n0,170,10\n30,179.9,10\n60,179.9,20\n90,179.8,30\n")
    b.write_text("md_m,inc_deg,azi_deg\n0,170,10\n30,179.9,190\n60,179.9,200\n90,179.8,210\n")
    rc, out, err = run(capsys, "compare", a, b, "--tool-model", "iscwsa-mwd-rev5", "--json")
    r = json.loads(out)
    assert [s["d_azi_deg"] is None for s in r["stations"]] == [False, True, True, True], out
    assert rc == 0, out + err


def test_inclination_spread_at_the_vertical_is_that_of_a_tilt_length(tmp_path, capsys):
    """At the vertical the inclination is the length of the tilt vector
    (Rayleigh-distributed, docs/survey.md), so the difference of two
    surveys' inclinations spreads by sqrt((4 - pi) / 2) = 0.66 of the
    linearised sigma: compare held vertical pairs to an effective k of 4.6
    instead of 3.  Pairs drawn with the model's own per-survey tilt spread:
    |d inc| / sigma has an RMS of 1 three degrees off the vertical, and at
    it 0.88 (0.83-0.94 over 12 draws of 300 pairs): the true tilt is
    estimated from the two surveys alone, above zero more often than not,
    so the sigma there stays a little wide -- against 0.62 before."""
    from inclino.survey import compare, geomag, models

    n = 300
    md = np.arange(n) * 10.0
    rf = geomag.ReferenceField(0.0, 60.0, 50000.0, 1.0)
    model = models.ErrorModel(models.load("iscwsa-mwd-rev5"), None, None)
    for true_inc in (0.0, 3.0):
        s = compare.expected(model, md, np.full(n, max(true_inc, 1e-3)), np.full(n, 40.0), rf)[0] / np.sqrt(2.0)
        mean = np.array([np.radians(true_inc), 0.0])
        tilt = [np.degrees(np.hypot(*(mean[:, None] + np.radians(s) * RNG.standard_normal((2, n))))) for _ in "ab"]
        files = []
        for name, inc in zip("ab", tilt):
            f = tmp_path / f"{name}{true_inc}.csv"
            f.write_text("md_m,inc_deg,azi_deg\n" + "".join(f"{m},{i},{RNG.uniform(0, 360)}\n" for m, i in zip(md, inc)))
            files.append(f)
        rc, out, err = run(capsys, "compare", *files, "--tool-model", "iscwsa-mwd-rev5", "--json")
        z = np.array([st["d_inc_deg"] / st["sigma_d_inc_deg"] for st in json.loads(out)["stations"]])
        lo = 0.75 if true_inc == 0.0 else 0.85
        assert lo < np.sqrt(np.mean(z ** 2)) < 1.15, (true_inc, np.sqrt(np.mean(z ** 2)))
