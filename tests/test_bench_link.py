"""`inclino bench link --json` runs its own emulated probe and reports
figures that are consistent with their definitions (the targets are the
benchmark's business, not this test's)."""
import json

from inclino import cli


def test_bench_link_figures(capsys):
    assert cli.main(["bench", "link", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["download_min_bytes"] == 256 and d["stream_frames"] == 200
    assert d["download_ratio"] == d["download_bytes"] / 256
    assert d["download_verify_bytes"] > d["download_bytes"]
    assert 0 < d["stream_link_fraction"] <= 1.0  # cannot beat the line
    assert d["pass"] == (d["stream_link_fraction"] >= 0.9 and d["download_ratio"] <= 1.5)
