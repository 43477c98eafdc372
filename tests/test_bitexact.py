"""The firmware C and the golden model agree bit for bit on a million
vectors plus the edge cases, and the comparison does catch a difference."""
import numpy as np

from inclino.engines import bitexact, golden
from inclino import cli


def test_million_vectors_zero_mismatches(capsys):
    assert cli.main(["bitexact", "--vectors", "1000000", "--seed", "11"]) == 0
    out = capsys.readouterr().out.strip()
    assert out.startswith("bitexact: ") and out.endswith(" 0 mismatches")
    assert int(out.split()[1]) >= 1_000_000


def test_edge_cases_cover_every_flag():
    rng = np.random.default_rng(0)
    cals = bitexact.random_cals(rng, 16)
    acc, mag = bitexact.edge_vectors()
    idx = np.arange(len(acc)) % len(cals)
    arr = [np.array([getattr(c, k) for c in cals], dtype=np.int64)[idx]
           for k in ("acc_m", "acc_b", "mag_m", "mag_b")]
    flags = np.bitwise_or.reduce(golden.survey_compute(acc, mag, *arr)["flags"])
    for bit in golden.FLAG_NAMES:
        assert flags & bit, golden.FLAG_NAMES[bit]


def test_comparison_detects_a_one_lsb_difference(monkeypatch, capsys):
    real = golden.fx_atan2_q16

    def off_by_one(y, x):
        r = real(y, x)
        return r + ((np.asarray(y) % 1009) == 7)

    monkeypatch.setattr(golden, "fx_atan2_q16", off_by_one)
    assert cli.main(["bitexact", "--vectors", "20000"]) == 1
    out = capsys.readouterr().out
    assert " 0 mismatches" not in out


def test_temperature_path_difference_is_caught(monkeypatch, capsys):
    """A one-LSB slip in the golden model's evaluation of the temperature
    terms is found: the temperature path is compared."""
    real = golden.corr_temp_eval

    def off_by_one(dt, *args):
        beff, e, sat = real(dt, *args)
        return beff + ((np.asarray(e) % 1013) == 5), e, sat

    monkeypatch.setattr(golden, "corr_temp_eval", off_by_one)
    assert cli.main(["bitexact", "--vectors", "20000"]) == 1
    assert " 0 mismatches" not in capsys.readouterr().out


def test_temperature_edges_reach_every_clamp():
    """The edge temperatures and the limit terms drive dT's clamps, e's
    clamp and b_eff's saturation (the arith-saturated flag) in the golden
    model the comparison runs."""
    rng = np.random.default_rng(1)
    tc = bitexact.random_temp_cals(rng, bitexact.random_cals(rng, 12))
    _, sat_dt = golden.corr_temp_dt(np.array(bitexact.EDGE_TEMPS), 0)
    assert sat_dt.any() and not sat_dt.all()
    hit = False
    for c in tc:
        t = c.temp
        dt, _ = golden.corr_temp_dt(np.array(bitexact.EDGE_TEMPS), t.t_ref)
        _, e, sat = golden.corr_temp_eval(dt, c.acc_b, t.acc_c1, t.acc_c2, t.acc_r1, t.acc_r2)
        hit |= bool(sat.any() and (np.abs(e) == golden.E_MAX).any())
    assert hit
