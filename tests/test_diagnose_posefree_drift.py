"""A field drift on a hand-held step-and-hold log without poses.

The data come from a simulator written here on its own (numpy only, from
docs/conventions.md: body = C . world, gravity [0, 0, 1] g, the field
F [cos dip, 0, sin dip]): a sensor with offsets, scales, cross-axis terms and
a misalignment, held at random orientations for 3 s each and turned by hand
in between, read at 10 Hz.  On hold means the driver of a field drift (time)
is also set against its own circular shifts; a ramp rolled by a third of the
run is still correlated about 0.3 with itself, so a drift that is there
leaked into its own null and was refused (0.05 nT/s on |b|, p 7e-15, read as
p 0.03 against its shifts, on 4 of 4 draws).
"""
import numpy as np
import pytest

from indep import DIP_DEG as DIP, F_NT, canonical_csv, sensor_matrix
from inclino.diagnose.analysis import diagnose
from inclino.formats.dataset import read_raw


def _rot(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def hand_holds(seed, drift_nT_s=0.0, holds=40, hold=30, move=20, rate=10.0, mag_mis=0.5):
    rng = np.random.default_rng(seed)
    sa, sm = sensor_matrix(rng), sensor_matrix(rng, mis=mag_mis)
    oa, om = rng.normal(0, 0.01, 3), rng.normal(0, 300.0, 3)
    rots = [_rot(rng) for _ in range(holds)]
    cs = []
    for k in range(holds):
        cs += [rots[k]] * hold
        if k + 1 < holds:  # the hand's turn to the next hold: a straight blend, re-orthonormalised
            for f in np.linspace(0, 1, move + 2)[1:-1]:
                u, _, vt = np.linalg.svd((1 - f) * rots[k] + f * rots[k + 1])
                cs.append(u @ vt)
    cs = np.array(cs)
    n = len(cs)
    t = np.arange(n) / rate
    dp = np.radians(DIP)
    fw = F_NT * np.array([np.cos(dp), 0.0, np.sin(dp)])
    size = 1.0 + drift_nT_s * (t - t.mean()) / F_NT
    g = cs @ np.array([0, 0, 1.0])
    b = np.einsum("nij,j->ni", cs, fw) * size[:, None]
    acc = g @ sa.T + oa + rng.normal(0, 1.5e-4, (n, 3))
    mag = b @ sm.T + om + rng.normal(0, 5.0, (n, 3))
    return canonical_csv(t, acc, mag)


def _read(tmp_path, text):
    p = tmp_path / "holds.csv"
    p.write_text(text)
    return read_raw(str(p))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_field_drift_on_hand_held_holds_is_named(tmp_path, seed):
    true = 0.05
    r = diagnose(_read(tmp_path, hand_holds(seed, true)))
    assert r.baseline["holds"]["moving_rows_left_out"]
    got = [e for e in r.effects if (e.name, e.sensor, e.axis) == ("field-drift", "field", "total")]
    assert got, (r.names(), r.baseline["selection"]["steps"])
    assert abs(got[0].estimate - true) < 3 * got[0].stderr, (got[0].estimate, got[0].stderr)
    assert len(r.effects) == 1, r.names()


def test_the_same_holds_without_a_drift_name_nothing(tmp_path):
    r = diagnose(_read(tmp_path, hand_holds(0, 0.0)))
    assert not r.effects, r.names()


def _mag_only(text):
    lines = text.splitlines()
    out = []
    for ln in lines:
        if ln.startswith("#"):
            out.append(ln)
            continue
        c = ln.split(",")
        out.append(",".join([c[0], *c[4:7]]))
    return "\n".join(out) + "\n"


def test_a_magnetometer_held_less_than_half_the_windows_finds_its_holds(tmp_path):
    """A magnetometer alone, held 30 rows between turns of 20: 21 of every
    50 ten-row windows lie wholly in a hold, so the median window moves and
    its spread (about 900 nT against 5 nT of noise) let the rows at either
    end of each turn pass as still: 63 holds of 40, their means carrying
    part of the turn, and the null read as structure no effect explains
    (Ljung-Box p 2e-4).  The still windows' own spread is the noise."""
    from inclino import holds
    ds = _read(tmp_path, _mag_only(hand_holds(1)))
    h = holds.find(ds)
    assert h.count == 40, h.to_dict()
    assert np.all(h.noise["mag"] < 10.0), h.noise
    assert h.rows_held == 40 * 30, h.to_dict()
    r = diagnose(ds)
    assert not r.effects and not r.unexplained, (r.names(), r.structure if hasattr(r, "structure") else None)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_fit_turns_the_magnetometer_onto_the_accelerometer(tmp_path, seed):
    """The triads' relative turn starts at zero (each ellipsoid start is
    symmetric); with the magnetometer turned about 2.5 deg against the
    accelerometer, Gauss-Newton along the turn's tangent lengthened every
    reading (1 + angle^2 / 2: tens of nT of |b|), each step was halved and
    the fit stopped with the dip far off: "the pose-free baseline fit
    failed".  Noise on the hold means: 1e-3 deg of dip."""
    r = diagnose(_read(tmp_path, hand_holds(seed, mag_mis=1.5)))
    assert r.baseline["fit_failed"] is None, r.baseline["fit_failed"]
    assert r.baseline["rms"]["dip"] < 0.01, r.baseline["rms"]
