"""Weak-form terms assembled alone on a tiny mesh against hand values."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.forms import friction
from dpcollapse.rheology.drucker_prager import DruckerPrager


@pytest.fixture
def square():
    msh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (0.3, 0.2), (3, 2))
    V = compat.vector_space(msh, 2)
    return msh, V


def _const(msh, v):
    return fem.Constant(msh, compat.ScalarType(v))


def test_side_wall_friction_term(square):
    """(2/w) ∫ μ_w [p]_+ u·v/√(|u|²+ε²) with u = v = (U, 0), p = P: (2/w) μ_w P U²/√(U²+ε²) |Ω|."""
    msh, V = square
    U, P, w, mu, eps = 0.7, 900.0, 0.1, math.tan(math.radians(10.2)), 1e-6
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([np.full(x.shape[1], U), np.zeros(x.shape[1])]))
    form = friction.side_wall_friction(w, mu, _const(msh, P), u, eps, u, u)
    value = fem.assemble_scalar(fem.form(form))
    assert value == pytest.approx(2 / w * mu * P * U**2 / math.sqrt(U**2 + eps**2) * 0.06, rel=1e-10)
    # tension: no friction
    assert (
        fem.assemble_scalar(fem.form(friction.side_wall_friction(w, mu, _const(msh, -P), u, eps, u, u)))
        == 0.0
    )


def test_coulomb_friction_on_the_bed(square):
    """∫_bed μ [p − σ'_nn]_+ u_T·v_T/√(|u_T|²+ε_f²) ds, sliding u = (U, 0) on y = 0 (length 0.3)."""
    msh, V = square
    U, P, mu, eps = 0.5, 1200.0, 0.4, 1e-6
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([np.full(x.shape[1], U), np.zeros(x.shape[1])]))
    fdim = 1
    facets = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[1], 0.0))
    tags = compat.meshtags(msh, fdim, facets, np.ones_like(facets))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    n = ufl.FacetNormal(msh)
    sigma = DruckerPrager(1.0, 0.5).deviatoric_stress(u, _const(msh, P), 1e-6)  # uniform u: σ' = 0
    normal = friction.normal_pressure(_const(msh, P), sigma, n)
    value = fem.assemble_scalar(fem.form(friction.coulomb_friction(mu, normal, u, eps, u, u, n, ds(1))))
    assert value == pytest.approx(mu * P * U**2 / math.sqrt(U**2 + eps**2) * 0.3, rel=1e-10)


def test_drucker_prager_cohesion_in_simple_shear(square):
    """τ → κ0 + μ_s p as ε → 0 (and κ0 alone under tension)."""
    msh, _ = square
    V = compat.vector_space(msh, 2)
    g = 2.0
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([g * x[1], 0 * x[0]]))
    law = DruckerPrager(0.0, 0.45, cohesion=150.0)
    for p, expected in ((1000.0, 150.0 + 450.0), (-50.0, 150.0)):
        s = law.deviatoric_stress(u, _const(msh, p), 1e-9)
        tau = fem.assemble_scalar(fem.form(s[0, 1] * ufl.dx)) / 0.06
        assert tau == pytest.approx(expected, rel=1e-9)


def test_drucker_prager_without_friction_and_cohesion_is_newtonian(square):
    """μ_s = κ0 = 0: τ = η γ̇ in simple shear, whatever the pressure (a Newtonian fluid)."""
    msh, _ = square
    V = compat.vector_space(msh, 2)
    g, eta = 2.0, 0.7
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([g * x[1], 0 * x[0]]))
    law = DruckerPrager(eta, 0.0)
    for p in (1000.0, -50.0):
        s = law.deviatoric_stress(u, _const(msh, p), 1e-6)
        tau = fem.assemble_scalar(fem.form(s[0, 1] * ufl.dx)) / 0.06
        assert tau == pytest.approx(eta * g, rel=1e-12)
