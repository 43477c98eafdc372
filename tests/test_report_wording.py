"""Figures the calibration and diagnosis reports print, in words a reader
new to the tools follows: the field a magnetometer-only calibration scaled
|b| to (and where it came from), what the pose-free fit's s^2 is against,
and a residual that is not white noise."""
import json
from pathlib import Path

import pytest

from inclino.cli import main
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"


def _imported(log, desc, tmp_path, drop=(), mag_scale=1.0):
    ds = importlog.import_log(str(REAL / log), sensor.load(str(REAL / desc)))[0]
    for k in drop:
        ds.meta.pop(k, None)
    for c in dataset.MAG_COLS:
        if c in ds.columns:
            ds.columns[c] = ds.columns[c] * mag_scale
    p = tmp_path / "run.csv"
    dataset.write_raw(str(p), ds)
    return str(p)


@pytest.mark.parametrize("drop,source", [((), "the header's field_nT"),
                                         (("field_nT",), "the radius of the sphere the raw readings lie on")])
def test_a_magnetometer_only_calibration_says_the_field_it_scaled_b_to(tmp_path, capsys, drop, source):
    # without the header's field the readings' own 10 440 nT is outside the geomagnetic range (exit 2): the
    # readings at the site's field (the scale the description's comment leaves open), 2.2x
    run = _imported("qmc5883l/filtered_raw_data.csv", "qmc5883l/sensor.toml", tmp_path, drop,
                    2.2 if drop else 1.0)
    cal = str(tmp_path / "cal.json")
    assert main(["calibrate", run, "-o", cal]) in (0, 1)
    line = [ln for ln in capsys.readouterr().out.splitlines() if "|b| normalised to" in ln]
    assert len(line) == 1 and source in line[0], line
    assert ("inclino reffield" in line[0]) == bool(drop)
    r = json.loads(Path(cal).read_text())["report"]["residuals"]
    assert r["field_from"].startswith(source)
    if not drop:
        assert r["field_nT"] == 23036.0
    else:  # the readings' own sphere: 1 253 counts at 1/12000 G (the description's comment), 2.2x
        assert 22_000 < r["field_nT"] < 24_000
        assert f"|b| normalised to {r['field_nT']:.0f} nT" in line[0]


def test_the_pose_free_s2_says_what_it_is_against(tmp_path, capsys):
    run = _imported("sap6/BB.csv", "sap6/sensor.toml", tmp_path)
    assert main(["calibrate", run, "-o", str(tmp_path / "cal.json")]) in (0, 1)
    out = capsys.readouterr().out
    assert "s^2, the residuals' variance over the noise assumed: acc " in out
    assert " against 0.15 mg, the nominal reading noise; mag " in out and "against its own |b| and dip scatter" in out


def test_a_residual_that_is_not_white_noise_is_said_in_words():
    from inclino.diagnose.result import _structure_text

    x = {"channel": "|b|", "test": "whiteness", "p": 1.1e-31}
    assert _structure_text(x) == ("|b| residual not white noise (serially correlated: neighbouring rows' residuals "
                                  "alike; Ljung-Box p = 1.1e-31)")
    assert _structure_text({"channel": "dip", "test": "mag direction", "p": 4e-188}) == \
        "dip residual vs mag direction (p = 4e-188)"
