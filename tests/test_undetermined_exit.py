"""A fit the readings do not determine is refused with exit 3, whichever
stage finds it (docs/cli.md): readings on no ellipsoid (the algebraic start)
as much as orientations that leave the fitted ellipsoid free."""
import numpy as np

from inclino.cli import main
from inclino.errors import CalibrationError, DataError, UndeterminedError


def _write(path, acc):
    with open(path, "w") as fh:
        fh.write("ax_g,ay_g,az_g\n")
        for r in acc:
            fh.write(",".join(f"{v:.7f}" for v in r) + "\n")


def test_readings_on_no_ellipsoid_are_a_singular_fit(tmp_path, capsys):
    rng = np.random.default_rng(1)
    # readings on a hyperboloid of one sheet (x^2 + y^2 - z^2 = 1): every row at rest, each its own
    # orientation, and no ellipsoid through them
    th, z = rng.uniform(0, 2 * np.pi, 400), rng.uniform(-0.8, 0.8, 400)
    r = np.sqrt(1 + z * z)
    acc = np.column_stack([r * np.cos(th), r * np.sin(th), z]) + rng.normal(0, 1e-3, (400, 3))
    p = tmp_path / "hyper.csv"
    _write(p, acc)
    code = main(["calibrate", str(p), "-o", str(tmp_path / "cal.json"), "--static"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "do not lie on an ellipsoid" in err and err.count("\n") == 1
    assert not (tmp_path / "cal.json").exists()


def test_the_undetermined_error_is_caught_as_either_kind():
    e = UndeterminedError("x")
    assert isinstance(e, DataError) and isinstance(e, CalibrationError) and e.exit_code == 3


def test_readings_at_one_orientation_are_said_to_be_at_one():
    """An accelerometer on a floor robot, turned only about the vertical:
    every reading within a few degrees of one direction was told "readings
    on a few circles or in a plane"; readings on a circle still are."""
    import pytest

    from inclino.calib.ellipsoid import ellipsoid_start

    rng = np.random.default_rng(3)
    one = np.array([0.03, -0.02, 1.0]) + rng.normal(0, 0.01, (300, 3))
    with pytest.raises(UndeterminedError, match=r"every reading within [\d.]+ deg of one direction"):
        ellipsoid_start(one, 1.0, "the accelerometer")
    th = rng.uniform(0, 2 * np.pi, 300)
    circle = np.column_stack([np.cos(th), np.sin(th), np.zeros(300)]) + rng.normal(0, 1e-3, (300, 3))
    with pytest.raises(UndeterminedError, match="readings on a few circles or in a plane"):
        ellipsoid_start(circle, 1.0, "the accelerometer")
