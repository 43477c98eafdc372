"""The pose-free ellipsoid fit (calib.triad.fit_sphere) of holds on one side
of the sphere: its residual |M (raw - b)| - R is in corrected units, which a
smaller M shrinks, and on such holds it ran away to an ellipsoid through a
plane and the triad was refused as "turned about one axis" (the first 6 000
rows of mikoff's MPU-9150, 61 holds, every x at -0.27 g or more).  Where it
runs away, the fit of the readings' distance from the ellipsoid is taken,
and it finds the simulated sensor."""
import numpy as np
import pytest

from inclino.calib import triad


def _one_sided(seed, holds, xmin=0.3, rows=300, noise=0.006):
    """holds orientations drawn on the cap x >= xmin (g), rows readings each,
    of an accelerometer with scale errors S and offsets b, noise per axis."""
    rng = np.random.default_rng(seed)
    d = []
    while len(d) < holds:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        if u[0] >= xmin:
            d.append(u)
    S = np.diag([1.01, 0.99, 1.02])
    b = np.array([0.01, -0.02, 0.03])
    g = np.repeat(np.array(d), rows, axis=0)
    return g @ S.T + b + rng.normal(0.0, noise, g.shape), S, b


@pytest.mark.parametrize("seed,holds", [(0, 13), (1, 13), (2, 13), (0, 20)])
def test_holds_on_one_side_fit_the_sensor_instead_of_running_away(seed, holds):
    raw, S, b = _one_sided(seed, holds)
    M, bb, cov, info = triad.fit_sphere(raw, 1.0, 0.004, what="the accelerometer")
    assert np.allclose(M @ S, np.eye(3), atol=0.02)  # M undoes the scale errors
    assert np.allclose(bb, b, atol=0.015)
    c = (raw - bb) @ M.T
    assert triad.direction_spread(c) > 0.05  # the corrected readings span 3-D, as the readings do
    assert np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0)


def test_readings_about_one_axis_are_still_refused():
    # a circle of orientations (turned about x only) determines no ellipsoid: refused as before
    rng = np.random.default_rng(4)
    a = rng.uniform(0, 2 * np.pi, 3000)
    g = np.column_stack([np.full_like(a, 0.2), np.cos(a), np.sin(a)])
    g /= np.linalg.norm(g, axis=1)[:, None]
    raw = g + [0.01, -0.02, 0.03] + rng.normal(0.0, 0.004, g.shape)
    with pytest.raises(Exception) as e:
        triad.fit_sphere(raw, 1.0, 0.004, what="the accelerometer")
    assert "ellipsoid" in str(e.value)
