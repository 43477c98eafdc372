"""Figures the calibration and diagnosis reports print, in words a reader
new to the tools follows: the field a magnetometer-only calibration scaled
|b| to (and where it came from), what the pose-free fit's s^2 is against,
and a residual that is not white noise."""
import json
import re
from pathlib import Path

import pytest

from inclino.cli import main
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"


def _imported(log, desc, tmp_path, drop=(), mag_scale=1.0, meta=None, name="run.csv"):
    ds = importlog.import_log(str(REAL / log), sensor.load(str(REAL / desc)))[0]
    for k in drop:
        ds.meta.pop(k, None)
    ds.meta.update(meta or {})
    for c in dataset.MAG_COLS:
        if c in ds.columns:
            ds.columns[c] = ds.columns[c] * mag_scale
    p = tmp_path / name
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
    assert " against 0.15 mg, the nominal noise (an ADIS16210-class reading; the data declare none)); mag " in out
    # s^2 said beside the residual scale it comes from: sqrt(s^2) x 0.15 mg
    s2, scale = re.search(r"acc ([\d.e+]+) \(a residual scale of ([\d.]+) mg against 0.15 mg", out).groups()
    assert float(scale) == pytest.approx(0.15 * float(s2) ** 0.5, rel=2e-3)
    assert "against its own scatter: the |b| residual of its ellipsoid fit and the dip's robust spread" in out
    assert "near 1" not in out


def test_the_pose_free_s2_is_against_the_declared_noise(tmp_path, capsys):
    """An ICM-20948 log whose description declares 2.3 mg: the line said
    'acc 8e+04 against 0.15 mg, the nominal reading noise; mag 0.41 against
    its own |b| and dip scatter, so near 1'.  The fit assumes the declared
    noise, which changes what s^2 is against and not the figures (each
    triad's covariance is scaled by its own s^2)."""
    plain = _imported("sap6/BB.csv", "sap6/sensor.toml", tmp_path)
    said = _imported("sap6/BB.csv", "sap6/sensor.toml", tmp_path, meta={"acc_noise_g": 2.3e-3}, name="said.csv")
    reps = []
    for run, cal in ((plain, "plain.json"), (said, "said.json")):
        assert main(["calibrate", run, "-o", str(tmp_path / cal)]) in (0, 1)
        reps.append(json.loads((tmp_path / cal).read_text())["report"])
    out = capsys.readouterr().out
    line = [ln for ln in out.splitlines() if "the residuals' variance over the noise assumed" in ln][-1]
    assert " against 2.3 mg, the noise the sensor description declares); mag " in line and "near 1" not in line
    (p, d) = (r["uncertainty"] for r in reps)
    assert d["predicted_azi_rms_deg"] == pytest.approx(p["predicted_azi_rms_deg"], rel=1e-6)
    assert d["predicted_inc_rms_deg"] == pytest.approx(p["predicted_inc_rms_deg"], rel=1e-6)
    for k, v in p["sigma"].items():
        assert d["sigma"][k] == pytest.approx(v, rel=1e-5, abs=1e-12)


def test_a_residual_that_is_not_white_noise_is_said_in_words():
    from inclino.diagnose.result import _structure_text

    x = {"channel": "|b|", "test": "whiteness", "p": 1.1e-31}
    assert _structure_text(x) == ("|b| residual not white noise (serially correlated: neighbouring rows' residuals "
                                  "alike; Ljung-Box p = 1.1e-31)")
    assert _structure_text({"channel": "dip", "test": "mag direction", "p": 4e-188}) == \
        "dip residual vs mag direction (p = 4e-188)"
