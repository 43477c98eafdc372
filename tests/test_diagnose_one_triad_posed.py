"""diagnose on a one-triad run with the turntable's poses: the diagnosis is
pose-free (the pose-based model needs both triads), and what it cannot
test is said to need that model, not "the poses" the run has.  The run is
generated here (docs/conventions.md's pose, an affine sensor, Gaussian
noise), not with inclino.model."""
import numpy as np

from indep import body
from inclino import cli


def _run(path, rng, triad, posed, n=60):
    I = np.degrees(np.arccos(rng.uniform(-1, 1, n)))
    A, T = rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    if triad == "acc":
        v, sd, b0, names = np.array([0.0, 0.0, 1.0]), 1.5e-4, 5e-3, ["ax_g", "ay_g", "az_g"]
    else:
        v, sd, b0, names = 50000.0 * np.array([np.cos(np.radians(60)), 0.0, np.sin(np.radians(60))]), 15.0, 300.0, \
            ["mx_nT", "my_nT", "mz_nT"]
    raw = body(I, A, T, v) @ (np.eye(3) + rng.normal(0, 4e-3, (3, 3))).T + rng.normal(0, b0, 3)
    raw += rng.normal(0, sd, raw.shape)
    cols = (["inc_deg", "azi_deg", "tf_deg"] if posed else []) + names
    data = np.column_stack(([I, A, T] if posed else []) + [raw])
    with open(path, "w") as f:
        f.write("# field_nT=50000\n# dip_deg=60\n" + ",".join(cols) + "\n")
        f.writelines(",".join(f"{x:.9g}" for x in r) + "\n" for r in data)


def test_a_posed_one_triad_run_is_not_told_its_effects_need_the_poses(tmp_path, capsys):
    rng = np.random.default_rng(41)
    for triad in ("acc", "mag"):
        for posed in (True, False):
            path = tmp_path / f"{triad}_{posed}.csv"
            _run(path, rng, triad, posed)
            assert cli.main(["diagnose", str(path)]) == 0
            out = capsys.readouterr().out
            lines = [ln for ln in out.splitlines() if "turntable-inclination-offset" in ln]
            assert len(lines) == 1, out
            if posed:  # the run has them: what is missing is the pose-based model's other triad
                assert lines[0].startswith("  needs the pose-based model (both triads): "), lines
            else:
                assert lines[0].startswith("  needs the poses: "), lines
