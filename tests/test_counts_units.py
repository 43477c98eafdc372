"""Counts that no unit fixes, and counts whose lsb is off by a factor that is
not a power of 2: the units check names what to write (docs/dataset.md)."""
import re

import numpy as np
from scipy.spatial.transform import Rotation

from inclino.cli import main

TOML = """name = "test triad, raw counts"
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "counts"
lsb = "{lsb}"
axes = "x = ax, y = ay, z = az"
"""


def _log(path, counts):
    with open(path, "w") as fh:
        fh.write("ax,ay,az\n")
        for r in counts:
            fh.write(",".join(f"{v:.0f}" for v in r) + "\n")


def _g(n=600, seed=3):
    rng = np.random.default_rng(seed)
    return Rotation.random(n, random_state=seed).as_matrix()[:, :, 2] + rng.normal(0, 1e-3, (n, 3))


def test_unsigned_counts_centred_on_mid_scale_are_named(tmp_path, capsys):
    # a 16-bit ADC: 32768 at zero g, 4060 counts a g; declared signed at 1/16384 g a count
    _log(tmp_path / "adc.csv", 32768 + 4060 * _g())
    (tmp_path / "s.toml").write_text(TOML.format(lsb="1/16384 g"))
    code = main(["import", str(tmp_path / "adc.csv"), "--sensor", str(tmp_path / "s.toml"), "-o",
                 str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert "every axis reads about 32768 counts" in err and "zero = 32768" in err
    assert not (tmp_path / "run.csv").exists()


def test_counts_off_by_an_odd_factor_get_the_lsb_to_write(tmp_path, capsys):
    _log(tmp_path / "c.csv", 6000 * _g())  # 6000 counts a g, declared 1/16384 g: 0.366x, no power of 2
    (tmp_path / "s.toml").write_text(TOML.format(lsb="1/16384 g"))
    assert main(["import", str(tmp_path / "c.csv"), "--sensor", str(tmp_path / "s.toml"), "-o",
                 str(tmp_path / "run.csv")]) == 2
    err = capsys.readouterr().err
    m = re.search(r'lsb = "([^"]+)" would make it so', err)
    assert m, err
    # the lsb it gives imports the log without a unit error
    (tmp_path / "s2.toml").write_text(TOML.format(lsb=m.group(1)))
    assert main(["import", str(tmp_path / "c.csv"), "--sensor", str(tmp_path / "s2.toml"), "-o",
                 str(tmp_path / "run.csv")]) == 0
    assert "units" not in capsys.readouterr().err


def test_a_declared_zero_imports_unsigned_counts(tmp_path, capsys):
    _log(tmp_path / "adc.csv", 32768 + 4060 * _g())
    (tmp_path / "s.toml").write_text(TOML.format(lsb="1/4060 g") + "zero = 32768\n")
    assert main(["import", str(tmp_path / "adc.csv"), "--sensor", str(tmp_path / "s.toml"), "-o",
                 str(tmp_path / "run.csv")]) == 0
    assert "units" not in capsys.readouterr().err
    head = (tmp_path / "run.csv").read_text().splitlines()
    assert any(line.startswith("# acc_unit=counts") and "less a zero of 32768" in line for line in head)
    (tmp_path / "bad.toml").write_text(TOML.format(lsb="1/4060 g") + 'zero = "mid"\n')
    assert main(["import", str(tmp_path / "adc.csv"), "--sensor", str(tmp_path / "bad.toml"), "-o",
                 str(tmp_path / "run2.csv")]) == 2
    assert "zero: a number" in capsys.readouterr().err
