"""Holds that leave a term of the ellipsoid free: a six-position phone log
whose holds all lie in the x-z and y-z planes (no orientation between x and
y) does not determine the x-y cross-axis term.  Refused, the refusal names
the term and the orientation that pins it down (it said "the readings do not
lie on an ellipsoid": the every-row fit's failure); fitted, the verdict
judges the inclination its coefficients' uncertainty predicts (it passed on
|g| alone with 1.08 deg predicted)."""
import numpy as np

from inclino import holds
from inclino.calib import motion
from inclino.cli import main
from inclino.errors import UndeterminedError
from inclino.formats.dataset import RawDataset


def _planes(seed=3):
    """Holds every 30 deg round the x-z and the y-z planes (40 rows each at
    1 mg), 23 rows between them moving with 150 mg of hand acceleration."""
    rng = np.random.default_rng(seed)
    a = np.radians(np.arange(0, 360, 30))
    dirs = np.concatenate([np.column_stack([np.sin(a), 0 * a, np.cos(a)]),
                           np.column_stack([0 * a, np.sin(a), np.cos(a)])])[np.argsort(np.tile(np.arange(12), 2),
                                                                                       kind="stable")]
    rows, prev = [], dirs[0]
    for d in dirs:
        for s in np.linspace(0, 1, 25)[1:-1]:
            v = (1 - s) * prev + s * d
            rows.append(v / np.linalg.norm(v) + rng.normal(0, 0.15, 3))
        rows += list(d + rng.normal(0, 1e-3, (40, 3)))
        prev = d
    acc = np.array(rows) * 1.01 + np.array([0.02, -0.01, 0.015])
    t = np.arange(len(acc)) / 50.0
    return RawDataset({"t_s": t, "ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2]}, {})


def test_the_free_term_is_named():
    ds = _planes()
    h = holds.find(ds)
    assert h.count >= 20
    text = holds.undetermined_text(ds, h.labels, h.count, "acc", "the accelerometer")
    assert text is not None and "x-y cross-axis" in text and "between the x and y axes" in text


def test_a_refusal_of_such_holds_names_the_term_not_the_ellipsoid():
    ds = _planes()
    h = holds.find(ds)
    e = UndeterminedError("the accelerometer's readings do not lie on an ellipsoid (too few orientations: ...)")
    why = motion.refusal(ds, e, None, (h.labels, h.count))
    assert why.startswith(f"the {h.count} holds found in the readings leave the accelerometer's x-y cross-axis")
    assert "fitted on every row instead" in why and "do not lie on an ellipsoid" in why
    # holds fitted alone (hs given, they passed the leverage test): the term they leave free, and what their fit met
    alone = motion.refusal(ds, e, (h.labels, h.count), (h.labels, h.count))
    assert alone.startswith(f"the {h.count} holds found in the readings leave the accelerometer's x-y cross-axis")
    assert "fitted on them alone: the accelerometer's readings do not lie on an ellipsoid" in alone
    assert "fitted on every row" not in alone
    # an error that names no triad: the fit's own error stands
    assert motion.refusal(ds, UndeterminedError("joint: too few rows"), (h.labels, h.count), None) is None


def test_a_fit_of_such_holds_fails_on_its_predicted_inclination(tmp_path, capsys):
    ds = _planes()
    p = tmp_path / "planes.csv"
    with open(p, "w") as fh:
        fh.write("t_s,ax_g,ay_g,az_g\n")
        for r in zip(*(ds.columns[c] for c in ("t_s", "ax_g", "ay_g", "az_g"))):
            fh.write(",".join(f"{v:.6f}" for v in r) + "\n")
    code = main(["calibrate", str(p), "-o", str(tmp_path / "cal.json")])
    out = capsys.readouterr().out
    assert code == 1
    assert "FAIL: coefficients poorly determined: predicted inclination 1-sigma (deg)" in out
