"""Closed-form local steps of the augmented Lagrangian against hand-computed values."""

import math

import numpy as np
import pytest

from dpcollapse.solvers import al_projection as al


def shear(g):
    """D of simple shear u = (g y, 0): |D| = g/√2."""
    return np.array([[0.0, g / 2], [g / 2, 0.0]])


def test_inside_the_yield_surface_is_rigid():
    sigma = np.array([[100.0, 30.0], [30.0, -100.0]])      # |σ'| = √(2·100² + 2·30²) = 147.6
    gamma = al.yield_multiplier(sigma, np.zeros((2, 2)), kappa=200.0, viscosity=1.0, r=10.0)
    assert np.array_equal(gamma, np.zeros((2, 2)))
    assert al.rigid(gamma)


def test_outside_the_yield_surface_by_hand():
    """τ = σ' + rD = [[0, 60], [60, 0]] (|τ| = 60√2 = 84.85), κ = 40, η = 1, r = 20:
    γ̇ = (1 − 40/84.85) τ / 22."""
    sigma = np.array([[0.0, 50.0], [50.0, 0.0]])
    D = shear(1.0)                                           # r D = [[0, 10], [10, 0]]
    gamma = al.yield_multiplier(sigma, D, kappa=40.0, viscosity=1.0, r=20.0)
    tau = np.array([[0.0, 60.0], [60.0, 0.0]])
    expected = (1 - 40 / (60 * math.sqrt(2))) / 22 * tau
    np.testing.assert_allclose(gamma, expected, rtol=1e-14)
    assert not al.rigid(gamma)


def test_zero_pressure_is_viscous():
    sigma, D = np.array([[2.0, 1.0], [1.0, -2.0]]), shear(0.3)
    gamma = al.yield_multiplier(sigma, D, kappa=0.0, viscosity=0.5, r=4.0)
    np.testing.assert_allclose(gamma, (sigma + 4.0 * D) / 5.0, rtol=1e-14)


def test_exact_solution_is_a_fixed_point():
    """With σ' = 2ηD + κ D/|D| (the law), the local step returns γ̇ = D and step 3 keeps σ'."""
    eta, kappa, r = 0.7, 300.0, 50.0
    D = shear(2.5)
    sigma = 2 * eta * D + kappa * D / np.linalg.norm(D)
    gamma = al.yield_multiplier(sigma, D, kappa, eta, r)
    np.testing.assert_allclose(gamma, D, rtol=1e-13)
    np.testing.assert_allclose(al.update_stress(sigma, D, gamma, r), sigma, rtol=1e-13)


def test_vectorized_over_points():
    sig = np.stack([np.zeros((2, 2)), np.array([[0.0, 50.0], [50.0, 0.0]])])
    D = np.stack([np.zeros((2, 2)), shear(1.0)])
    gamma = al.yield_multiplier(sig, D, kappa=np.array([10.0, 40.0]), viscosity=1.0, r=20.0)
    assert gamma.shape == (2, 2, 2)
    assert al.rigid(gamma).tolist() == [True, False]


def test_friction_stick_and_slip_by_hand():
    r_f, eta_f = 5.0, 0.0
    # stick: |σ_T − r_f u_T| = |(3, 0) − 5 (0.2, 0)| = 2 ≤ μ[−σ_n]_+ = 4  →  δ = 0
    delta = al.slip_multiplier(np.array([3.0, 0.0]), np.array([0.2, 0.0]), 4.0, eta_f, r_f)
    assert np.array_equal(delta, np.zeros(2))
    # slip: τ_T = (−12, 0), |τ_T| = 12 > 4  →  δ = −(1 − 4/12)(−12, 0)/5 = (1.6, 0)
    delta = al.slip_multiplier(np.array([-2.0, 0.0]), np.array([2.0, 0.0]), 4.0, eta_f, r_f)
    np.testing.assert_allclose(delta, [1.6, 0.0], rtol=1e-14)
    # no normal compression: no friction, δ = −τ_T/r_f
    delta = al.slip_multiplier(np.array([-2.0, 1.0]), np.array([2.0, 0.0]), 0.0, eta_f, r_f)
    np.testing.assert_allclose(delta, [12.0 / 5, -1.0 / 5], rtol=1e-14)


def test_friction_exact_slip_is_a_fixed_point():
    """Sliding with σ_T = −μ[−σ_n]_+ u_T/|u_T| (Coulomb): δ = u_T and σ_T is kept."""
    limit, r_f = 3.0, 7.0
    u_t = np.array([0.4, 0.0])
    sigma_t = -limit * u_t / np.linalg.norm(u_t)
    delta = al.slip_multiplier(sigma_t, u_t, limit, 0.0, r_f)
    np.testing.assert_allclose(delta, u_t, rtol=1e-13)
    np.testing.assert_allclose(al.update_traction(sigma_t, u_t, delta, r_f), sigma_t, rtol=1e-13)


@pytest.mark.parametrize("bad", [np.nan])
def test_nan_propagates_not_hidden(bad):
    gamma = al.yield_multiplier(np.full((2, 2), bad), np.zeros((2, 2)), 1.0, 1.0, 1.0)
    assert np.isnan(gamma).all()
