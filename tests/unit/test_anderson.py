"""Anderson acceleration of a fixed point, against plain iteration."""

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.solvers.anderson import Anderson


def _iterate(depth, M, c, tol=1e-10, cap=2000):
    x = np.zeros(len(c))
    acc = Anderson(MPI.COMM_SELF, depth, len(c))
    for k in range(1, cap + 1):
        g = M @ x + c
        if np.linalg.norm(g - x) < tol:
            return k, g
        x = acc.update(x, g)
    return cap, x


def test_anderson_accelerates_a_slow_linear_contraction():
    rng = np.random.default_rng(1)
    n = 40
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    M = Q @ np.diag(np.linspace(0.5, 0.98, n)) @ Q.T   # contraction 0.98: slow
    c = rng.normal(size=n)
    exact = np.linalg.solve(np.eye(n) - M, c)
    k_plain, x_plain = _iterate(0, M, c)
    k_aa, x_aa = _iterate(5, M, c)
    np.testing.assert_allclose(x_aa, exact, rtol=1e-7)
    np.testing.assert_allclose(x_plain, exact, rtol=1e-7)
    assert k_aa < k_plain / 5


def test_depth_zero_is_plain_iteration():
    acc = Anderson(MPI.COMM_SELF, 0, 3)
    x, g = np.zeros(3), np.array([1.0, 2.0, 3.0])
    assert np.array_equal(acc.update(x, g), g)
    assert np.array_equal(acc.update(g, 2 * g), 2 * g)


def test_weights_restrict_the_least_squares():
    """Entries with weight 0 do not influence the mixing coefficients."""
    w = np.array([1.0, 1.0, 0.0])
    a = Anderson(MPI.COMM_SELF, 3, 3, weights=w)
    b = Anderson(MPI.COMM_SELF, 3, 3, weights=w)
    xs = [np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.5, 7.0])]
    gs = [np.array([1.0, 0.5, 3.0]), np.array([1.4, 0.8, -2.0])]
    out_a = [a.update(x, g) for x, g in zip(xs, gs)][-1]
    gs_b = [g.copy() for g in gs]
    gs_b[1][2] = 100.0  # change only the unweighted entry of the image
    out_b = [b.update(x, g) for x, g in zip(xs, gs_b)][-1]
    assert out_a[:2] == pytest.approx(out_b[:2])
