"""`inclino bench input`: the peak memory it reports is the command's own,
not the bench process's (a child started by fork and exec carries the
parent's high-water mark in getrusage's ru_maxrss)."""
import sys

import numpy as np
import pytest

from inclino.benchmarks import input as bench_input


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="VmHWM is Linux's")
def test_the_peak_is_the_commands_own(tmp_path):
    big = np.ones(50_000_000)  # the bench process's own peak: 400 MB
    del big
    path = tmp_path / "l.csv"
    bench_input.write_listing(str(path), 500)
    r = bench_input.run_command(["trajectory", str(path), "--declination", "2", "-o", str(tmp_path / "p.csv")])
    assert r["exit"] == 0, r
    assert 10e6 < r["peak_rss_bytes"] < 300e6, r
