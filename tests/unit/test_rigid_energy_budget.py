"""studies/benchmarks/rigid_energy_budget.py (issue 51): the snapshot reader's integrals —
E_p and E_k exact on triangles, the P1 gradient, the bed's friction power with and without the
deviatoric normal stress — against hand values on a 2 × 1 rectangle."""

import math
import sys

import numpy as np
import pytest

from tests.helpers import ROOT

sys.path.insert(0, str(ROOT / "studies" / "benchmarks"))
import rigid_energy_budget as budget  # noqa: E402


def rectangle(nx=8, ny=4, length=2.0, height=1.0):
    """Vertices and triangles of [0, length] × [0, height], two triangles per square."""
    xs, ys = np.linspace(0, length, nx + 1), np.linspace(0, height, ny + 1)
    x = np.array([(a, b) for b in ys for a in xs])
    idx = lambda i, j: j * (nx + 1) + i   # noqa: E731
    cells = []
    for j in range(ny):
        for i in range(nx):
            cells += [(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)),
                      (idx(i, j), idx(i + 1, j + 1), idx(i, j + 1))]
    return x, np.array(cells)


def test_energies_exact_on_linear_fields():
    x, cells = rectangle()
    rho, g = 1550.0, 9.81
    # E_p = ρ g ∫ y dA = ρ g · 2 · ½
    assert budget.potential_energy(x, cells, rho, g) == pytest.approx(rho * g * 1.0, rel=1e-12)
    # u = (x, 0): E_k = ½ ρ ∫ x² dA = ½ ρ · (8/3) · 1
    u = np.stack([x[:, 0], np.zeros(len(x))], axis=1)
    assert budget.kinetic_energy(x, cells, u, rho) == pytest.approx(0.5 * rho * 8.0 / 3.0, rel=1e-12)


def test_gradient_of_a_linear_field():
    x, cells = rectangle()
    A = np.array([[0.3, -1.2], [2.0, 0.7]])
    u = x @ A.T
    assert np.allclose(budget.linear_gradients(x, cells, u), A, atol=1e-12)


@pytest.mark.parametrize("stretch", [0.0, 0.5])
def test_bed_friction_power(stretch):
    """A layer sliding at u_x = 1 + s x with u_y = −s y (div u = 0) under p = ρ g (1 − y):
    on the bed y = 0, P_bed(N = p) = μ_b ρ g ∫_0^2 (1 + s x) dx; with the deviatoric normal
    stress, D_yy = −s, |D| = √2 s, so σ'_nn = −κ/√2 − 2η s = −μ_s p − 2η s (s > 0):
    N = (1 + μ_s) p + 2η s."""
    x, cells = rectangle(nx=16, ny=4)
    rho, g, mu_b, mu_s, eta = 1550.0, 9.81, 0.5, 0.4, 1.0
    p = rho * g * (1.0 - x[:, 1])
    u = np.stack([1.0 + stretch * x[:, 0], -stretch * x[:, 1]], axis=1)
    bed = budget.boundary_edges(x, cells, lambda v: abs(v[1]) < 1e-9)
    assert len(bed) == 16
    p_only, full, s_nn, p_int = budget.wall_power(x, cells, p, u, bed, (0.0, -1.0),
                                                  mu_b, mu_s, eta, 1e-6)
    slip_integral = 2.0 + stretch * 2.0   # ∫_0^2 (1 + s x) dx
    assert p_only == pytest.approx(mu_b * rho * g * slip_integral, rel=1e-12)
    if stretch == 0.0:
        assert full == pytest.approx(p_only, rel=1e-12)
        assert s_nn == pytest.approx(0.0, abs=1e-9)
    else:
        expected = mu_b * ((1.0 + mu_s) * rho * g + 2.0 * eta * stretch) * slip_integral
        assert full == pytest.approx(expected, rel=1e-9)
        assert s_nn / p_int == pytest.approx(-(mu_s + 2.0 * eta * stretch / (rho * g)), rel=1e-9)
    assert math.isfinite(full)
