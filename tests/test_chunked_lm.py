"""calib/chunked_lm.py: the least-squares fits of a long run, their Jacobian
a chunk of rows at a time; the same minimum and J^T J as least_squares
(MINPACK lm) with the whole Jacobian, without holding it."""
import tracemalloc

import numpy as np
import pytest
from scipy import optimize

from inclino.calib import chunked_lm, covariance


def _problem(rng, n=4000):
    """A nonlinear fit of n rows, 6 residuals each, 12 parameters, scales
    differing by decades (as the temperature terms' g, nT and ppm do)."""
    t = rng.uniform(-1.0, 1.0, (n, 1))
    u = rng.normal(size=(n, 6))
    true = rng.normal(size=12) * np.repeat([1.0, 1e-3, 1e3], 4)
    scale = np.repeat([1.0, 1e3, 1e-3], 4)

    def model(x, rows):
        a, b = (x[:6] * scale[:6])[None, :], (x[6:] * scale[6:])[None, :]
        return a * np.sin(u[rows] + b * t[rows]) + b * t[rows] ** 2

    y = model(true, slice(None)) + 1e-3 * rng.normal(size=(n, 6))

    def fun(x, rows=slice(None)):
        return (model(x, rows) - y[rows]).ravel()

    return fun, true * (1 + 0.05 * rng.normal(size=12))


def test_the_minimum_and_jtj_are_least_squares_own(rng, monkeypatch):
    fun, x0 = _problem(rng)
    monkeypatch.setattr(chunked_lm, "CHUNK_ROWS", 6 * 700)  # several chunks, the last one short
    chunks = chunked_lm.row_chunks(4000, 6)
    assert len(chunks) == 6 and chunks[-1] == slice(3500, 4000)
    got = chunked_lm.solve(lambda x, c: fun(x, c), chunks, x0)
    want = optimize.least_squares(fun, x0, jac=lambda x: chunked_lm.jacobian_2point(fun, x), method="lm",
                                  x_scale="jac")
    J = want.jac
    sigma = np.sqrt(np.diag(np.linalg.inv(J.T @ J)) * 2 * want.cost / (J.shape[0] - J.shape[1]))
    assert got.status in (1, 2, 3)
    assert np.max(np.abs(got.x - want.x) / sigma) < 1e-3
    assert got.cost == pytest.approx(want.cost, rel=1e-9)
    assert got.m == J.shape[0]
    J = chunked_lm.jacobian_2point(fun, got.x)  # at the same x
    np.testing.assert_allclose(got.jtj, J.T @ J, rtol=1e-9, atol=1e-9 * np.abs(J.T @ J).max())


def test_a_fit_never_holds_the_whole_jacobian(rng, monkeypatch):
    """The peak of the numpy arrays allocated during the fit stays below one
    whole 6n x P Jacobian (what least_squares' lm held four of)."""
    n = 20000
    fun, x0 = _problem(rng, n)
    monkeypatch.setattr(chunked_lm, "CHUNK_ROWS", 6 * 1000)
    chunks = chunked_lm.row_chunks(n, 6)
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        chunked_lm.solve(lambda x, c: fun(x, c), chunks, x0)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    whole = 6 * n * len(x0) * 8
    assert peak < 0.5 * whole, (peak, whole)


def test_row_chunks_start_at_cluster_starts(monkeypatch):
    monkeypatch.setattr(chunked_lm, "CHUNK_ROWS", 60)  # 10 rows of 6
    starts = np.array([0, 3, 9, 12, 30, 31, 45])  # a cluster of 18 rows: one chunk of its own
    ch = chunked_lm.row_chunks(50, 6, starts)
    assert ch[0].start == 0 and ch[-1].stop == 50
    assert all(a.stop == b.start for a, b in zip(ch, ch[1:]))
    assert all(c.start in starts for c in ch)
    assert [(c.start, c.stop) for c in ch] == [(0, 9), (9, 12), (12, 30), (30, 31), (31, 45), (45, 50)]


@pytest.mark.parametrize("single", [False, True])
def test_the_whitener_a_part_at_a_time_is_the_whole(single, rng, monkeypatch):
    """ClusterWhitener.apply_rows over chunks of whole clusters gives the
    sum of squares, J^T J and J^T r of apply / apply_jac on every row."""
    n = 3000
    lab = np.arange(n) if single else np.cumsum(rng.random(n) < 0.3)
    A = rng.normal(size=(6, 6))
    k = len(np.unique(lab))
    B = rng.normal(size=(k, 6, 6))
    W = covariance.ClusterWhitener(A @ A.T + 6 * np.eye(6), 0.1 * B @ np.swapaxes(B, 1, 2), lab)
    r, J = rng.normal(size=(n, 6)), rng.normal(size=(n, 6, 5))
    monkeypatch.setattr(chunked_lm, "CHUNK_ROWS", 6 * 100)
    ch = chunked_lm.row_chunks(n, 6, W.starts())
    assert len(ch) > 20
    fr, fJ = W.apply(r), W.apply_jac(J)
    pr = np.concatenate([W.part(c).apply(r[c]) for c in ch])
    pJ = np.concatenate([W.part(c).apply_jac(J[c]) for c in ch])
    assert pr @ pr == pytest.approx(fr @ fr, rel=1e-12)
    np.testing.assert_allclose(pJ.T @ pJ, fJ.T @ fJ, rtol=1e-10)
    np.testing.assert_allclose(pJ.T @ pr, fJ.T @ fr, rtol=1e-9, atol=1e-9 * np.abs(fJ.T @ fr).max())
