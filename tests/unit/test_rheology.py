"""Unit tests of the regularized Drucker–Prager law and the norm convention."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.rheology.drucker_prager import DruckerPrager


def _shear_stress(eta, mu_s, p_value, gamma_dot, eps):
    """σ'_xy of the law for simple shear u = (γ̇ y, 0) at pressure p, averaged over a square."""
    msh = dmesh.create_unit_square(MPI.COMM_SELF, 2, 2)
    V = compat.vector_space(msh, 2)
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([gamma_dot * x[1], 0 * x[0]]))
    p = fem.Constant(msh, compat.ScalarType(p_value))
    sigma = DruckerPrager(eta, mu_s).deviatoric_stress(u, p, eps)
    return fem.assemble_scalar(fem.form(sigma[0, 1] * ufl.dx))


@pytest.mark.parametrize("gamma_dot", [0.1, 1.0, 30.0])
def test_simple_shear_gives_coulomb_stress(gamma_dot):
    """τ = η γ̇ + μ_s p γ̇/√(γ̇² + 2ε²) → η γ̇ + μ_s p as ε → 0 (Frobenius |D|)."""
    eta, mu_s, p = 0.7, math.tan(math.radians(25.5)), 2500.0
    for eps in (1e-2, 1e-4, 1e-6):
        tau = _shear_stress(eta, mu_s, p, gamma_dot, eps)
        expected = eta * gamma_dot + mu_s * p * gamma_dot / math.sqrt(gamma_dot**2 + 2 * eps**2)
        assert tau == pytest.approx(expected, rel=1e-12)
    assert _shear_stress(eta, mu_s, p, gamma_dot, 1e-8) == pytest.approx(
        eta * gamma_dot + mu_s * p, rel=1e-10
    )


def test_no_yield_stress_under_tension():
    """κ(p) = √2 μ_s [p]_+: a negative pressure gives no plastic stress."""
    tau = _shear_stress(0.0, 0.5, -1000.0, 1.0, 1e-6)
    assert tau == pytest.approx(0.0, abs=1e-12)


def test_parameters_are_validated():
    with pytest.raises(ValueError, match="viscosity"):
        DruckerPrager(-1.0, 0.5)
    with pytest.raises(ValueError, match="friction"):
        DruckerPrager(1.0, -0.1)
    DruckerPrager(1.0, 0.0)   # μ_s = 0: a Newtonian fluid
