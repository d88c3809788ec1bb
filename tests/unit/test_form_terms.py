"""Every weak-form term assembled alone on a small rectangle against a hand value.

Ω = [0, 0.3] × [0, 0.2] (|Ω| = 0.06, ∫x = 0.009, ∫y = 0.006), 3 × 2 squares cut in two
triangles each. The trial and test functions are replaced by given polynomial fields
(degree ≤ 2, represented exactly in P2), which turns each bilinear term into a number.
"""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.forms import augmented, friction, mesh_velocity, momentum
from dpcollapse.forms.picard import picard_terms
from dpcollapse.rheology.drucker_prager import DruckerPrager

LX, LY = 0.3, 0.2
AREA, INT_X, INT_Y = LX * LY, LX**2 / 2 * LY, LX * LY**2 / 2
BOTTOM, TOP = 1, 2


@pytest.fixture(scope="module")
def omega():
    msh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (LX, LY), (3, 2))
    V = compat.vector_space(msh, 2)
    Q = compat.scalar_space(msh, 1)
    fdim = 1
    bottom = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[1], 0.0))
    top = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[1], LY))
    tags = compat.meshtags(msh, fdim, np.concatenate([bottom, top]),
                           np.concatenate([np.full(len(bottom), BOTTOM), np.full(len(top), TOP)]))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    return msh, V, Q, ds


def vec(omega, fx, fy):
    """The P2 field (fx(x, y), fy(x, y))."""
    u = fem.Function(omega[1])
    u.interpolate(lambda x: np.vstack([fx(x[0], x[1]) + 0 * x[0], fy(x[0], x[1]) + 0 * x[0]]))
    return u


def scal(omega, f):
    p = fem.Function(omega[2])
    p.interpolate(lambda x: f(x[0], x[1]) + 0 * x[0])
    return p


def const(omega, value):
    return fem.Constant(omega[0], compat.ScalarType(value) if np.ndim(value) == 0
                        else np.asarray(value, dtype=compat.ScalarType))


def value(form):
    return fem.assemble_scalar(fem.form(form))


RHO, DT = 1550.0, 1e-3


# ------------------------------------------------------------------ forms.momentum
def test_inertia(omega):
    """∫ ρ u/Δt · v, u = (x, 0), v = (1, 0): ρ/Δt ∫x."""
    u, v = vec(omega, lambda x, y: x, lambda x, y: 0), vec(omega, lambda x, y: 1, lambda x, y: 0)
    got = value(momentum.inertia(const(omega, RHO), const(omega, DT), u, v))
    assert got == pytest.approx(RHO / DT * INT_X, rel=1e-12)


def test_previous_velocity(omega):
    """∫ ρ uⁿ/Δt · v, uⁿ = (y, 3), v = (1, 0): ρ/Δt ∫y (the y component does not enter)."""
    u_old, v = vec(omega, lambda x, y: y, lambda x, y: 3), vec(omega, lambda x, y: 1, lambda x, y: 0)
    got = value(momentum.previous_velocity(const(omega, RHO), const(omega, DT), u_old, v))
    assert got == pytest.approx(RHO / DT * INT_Y, rel=1e-12)


def test_convection(omega):
    """∫ ρ ((uᵏ − w)·∇) u · v, u = (y, 0), uᵏ − w = (2, 1) − (0.5, 3) = (1.5, −2), v = (1, 0):
    ρ (−2) |Ω| (only ∂u_x/∂y ≠ 0, so only the y component of uᵏ − w enters)."""
    u, v = vec(omega, lambda x, y: y, lambda x, y: 0), vec(omega, lambda x, y: 1, lambda x, y: 0)
    u_k, w = vec(omega, lambda x, y: 2, lambda x, y: 1), vec(omega, lambda x, y: 0.5, lambda x, y: 3)
    got = value(momentum.convection(const(omega, RHO), u_k, w, u, v))
    assert got == pytest.approx(RHO * (1 - 3) * AREA, rel=1e-12)


def test_viscoplastic(omega):
    """∫ S D(u):D(v), u = v = (y, 0): D:D = 1/2, so S |Ω|/2; u = (x, 0), v = (y, 0): 0."""
    S = const(omega, 7.0)
    shear = vec(omega, lambda x, y: y, lambda x, y: 0)
    stretch = vec(omega, lambda x, y: x, lambda x, y: 0)
    assert value(momentum.viscoplastic(S, shear, shear)) == pytest.approx(7.0 * 0.5 * AREA, rel=1e-12)
    assert value(momentum.viscoplastic(S, stretch, shear)) == pytest.approx(0.0, abs=1e-14)


def test_pressure(omega):
    """−∫ p div v, p = x, v = (x, 0): −∫x."""
    got = value(momentum.pressure(scal(omega, lambda x, y: x), vec(omega, lambda x, y: x, lambda x, y: 0)))
    assert got == pytest.approx(-INT_X, rel=1e-12)


def test_incompressibility(omega):
    """−∫ q div u, q = 2, u = (x, y): −4 |Ω|."""
    got = value(momentum.incompressibility(scal(omega, lambda x, y: 2.0),
                                           vec(omega, lambda x, y: x, lambda x, y: y)))
    assert got == pytest.approx(-4.0 * AREA, rel=1e-12)


def test_gravity(omega):
    """∫ ρ f·v, f = g (sin θ, −cos θ), v = (x, y): ρ g (sin θ ∫x − cos θ ∫y)."""
    g, theta = 9.81, math.radians(22.0)
    f = const(omega, (g * math.sin(theta), -g * math.cos(theta)))
    got = value(momentum.gravity(const(omega, RHO), f, vec(omega, lambda x, y: x, lambda x, y: y)))
    assert got == pytest.approx(RHO * g * (math.sin(theta) * INT_X - math.cos(theta) * INT_Y), rel=1e-12)


# ------------------------------------------------------------------ forms.friction
def test_coulomb_friction_drops_the_normal_component(omega):
    """On the top (n = (0, 1)): u = (U, 5) slides with u_T = (U, 0); v = (1, 7), v_T = (1, 0):
    μ [P − σ'_nn]_+ U/√(U² + ε²) · LX with σ'_nn = 0 (uniform u)."""
    msh, _, _, ds = omega
    U, P, mu, eps = 0.4, 800.0, 0.3, 1e-6
    u, v = vec(omega, lambda x, y: U, lambda x, y: 5), vec(omega, lambda x, y: 1, lambda x, y: 7)
    n = ufl.FacetNormal(msh)
    normal = friction.normal_pressure(const(omega, P), ufl.as_matrix([[0.0, 0.0], [0.0, 0.0]]), n)
    u_k = vec(omega, lambda x, y: U, lambda x, y: 0)
    got = value(friction.coulomb_friction(mu, normal, u_k, eps, u, v, n, ds(TOP)))
    assert got == pytest.approx(mu * P * U / math.sqrt(U**2 + eps**2) * LX, rel=1e-12)


def test_normal_pressure_subtracts_the_normal_deviatoric_stress(omega):
    """[p − n·σ'n]_+ on the bottom (n = (0, −1)): σ'_yy = 300 → [1000 − 300]_+ · LX; and 0
    when σ'_nn exceeds p."""
    msh, _, _, ds = omega
    n = ufl.FacetNormal(msh)
    sigma = ufl.as_matrix([[-300.0, 50.0], [50.0, 300.0]])
    assert value(friction.normal_pressure(const(omega, 1000.0), sigma, n) * ds(BOTTOM)) == \
        pytest.approx(700.0 * LX, rel=1e-12)
    assert value(friction.normal_pressure(const(omega, 200.0), sigma, n) * ds(BOTTOM)) == 0.0


# ------------------------------------------------------------------ forms.augmented
def test_augmented_viscous(omega):
    """∫ r D(u):D(v), u = v = (y, 0): r |Ω|/2."""
    shear = vec(omega, lambda x, y: y, lambda x, y: 0)
    assert value(augmented.augmented_viscous(const(omega, 120.0), shear, shear)) == \
        pytest.approx(120.0 * 0.5 * AREA, rel=1e-12)


def test_multiplier_stress(omega):
    """−∫ (σ' − r γ̇):D(v), v = (y, 0) (D = [[0, ½], [½, 0]]): −(σ'_xy − r γ̇_xy) |Ω|."""
    sigma = const(omega, [[10.0, 4.0], [4.0, -10.0]])
    gamma = const(omega, [[0.5, 0.25], [0.25, -0.5]])
    r = 8.0
    got = value(augmented.multiplier_stress(sigma, gamma, const(omega, r),
                                            vec(omega, lambda x, y: y, lambda x, y: 0)))
    assert got == pytest.approx(-(4.0 - r * 0.25) * AREA, rel=1e-12)


def test_boundary_augmentation(omega):
    """∫_Γ r_f u_T·v_T on the bottom: u = (x, 5), v = (1, 7): r_f ∫₀^LX x dx."""
    msh, _, _, ds = omega
    got = value(
        augmented.boundary_augmentation(
            const(omega, 30.0),
            vec(omega, lambda x, y: x, lambda x, y: 5),
            vec(omega, lambda x, y: 1, lambda x, y: 7),
            ufl.FacetNormal(msh),
            ds(BOTTOM),
        )
    )
    assert got == pytest.approx(30.0 * LX**2 / 2, rel=1e-12)


def test_boundary_multiplier(omega):
    """∫_Γ (σ_T + r_f δ)·v_T on the bottom: σ_T = (2, 9), δ = (1, 4), v = (1, 7):
    (2 + r_f) LX (normal components drop out)."""
    msh, _, _, ds = omega
    r_f = 30.0
    got = value(augmented.boundary_multiplier(vec(omega, lambda x, y: 2, lambda x, y: 9),
                                              vec(omega, lambda x, y: 1, lambda x, y: 4), const(omega, r_f),
                                              vec(omega, lambda x, y: 1, lambda x, y: 7),
                                              ufl.FacetNormal(msh), ds(BOTTOM)))
    assert got == pytest.approx((2 + r_f) * LX, rel=1e-12)


def test_volume_augmentation(omega):
    """∫ r_w u·v, u = (x, 0), v = (1, 1): r_w ∫x."""
    got = value(augmented.volume_augmentation(const(omega, 50.0), vec(omega, lambda x, y: x, lambda x, y: 0),
                                              vec(omega, lambda x, y: 1, lambda x, y: 1)))
    assert got == pytest.approx(50.0 * INT_X, rel=1e-12)


def test_volume_multiplier(omega):
    """∫ (σ_w + r_w δ_w)·v, σ_w = (1, 2), δ_w = (3, 4), v = (x, 0): (1 + 3 r_w) ∫x."""
    r_w = 50.0
    got = value(augmented.volume_multiplier(vec(omega, lambda x, y: 1, lambda x, y: 2),
                                            vec(omega, lambda x, y: 3, lambda x, y: 4), const(omega, r_w),
                                            vec(omega, lambda x, y: x, lambda x, y: 0)))
    assert got == pytest.approx((1 + 3 * r_w) * INT_X, rel=1e-12)


# ------------------------------------------------------------------ forms.mesh_velocity
def test_mesh_velocity_forms(omega):
    """a(w, z) = ∫ D(w):D(z) + (ξ̂/h) ∫_Γf (w·n)(z·n), L(z) = (ξ̂/h) ∫_Γf (u·n)(z·n) on the top
    (n = (0, 1)); w = z = (y, y): D:D = 3/2, w·n = 0.2 on y = 0.2; u = (0, x).
    h = CellDiameter = √2 · 0.1 (every cell is half a 0.1 × 0.1 square)."""
    ds = omega[3]
    xi, h = 1000.0, math.sqrt(2) * 0.1
    w = vec(omega, lambda x, y: y, lambda x, y: y)
    a, L = mesh_velocity.mesh_velocity_forms(w, w, vec(omega, lambda x, y: 0, lambda x, y: x), xi, ds(TOP))
    assert value(a) == pytest.approx(1.5 * AREA + xi / h * LY**2 * LX, rel=1e-12)
    assert value(L) == pytest.approx(xi / h * LY * LX**2 / 2, rel=1e-12)


# ------------------------------------------------------------------ forms.picard
def test_picard_terms_are_the_named_terms(omega):
    """picard_terms: the names of the regularized model, each the term of forms.momentum /
    forms.friction; the viscoplastic term carries the law's secant viscosity (simple shear
    u = (y, 0), p = P: S = κ(P)/|D|_ε + 2η, |D| = 1/√2)."""
    msh, _, _, ds = omega
    law = DruckerPrager(0.5, 0.4)
    P, eps = 600.0, 1e-6
    shear = vec(omega, lambda x, y: y, lambda x, y: 0)
    p = scal(omega, lambda x, y: P)
    lhs, rhs = picard_terms(
        law, rho=const(omega, RHO), dt=const(omega, DT), body_force=const(omega, (0.0, -9.81)),
        epsilon=eps, epsilon_friction=1e-6, u_iter=shear, p_iter=p, u_old=shear, mesh_velocity=shear,
        trial=(shear, p), test=(shear, p), n=ufl.FacetNormal(msh), ds=ds,
        friction_walls=[("bed_friction", 0.4, BOTTOM)], side_walls=(0.1, 0.2))
    assert list(lhs) == ["inertia", "convection", "viscoplastic", "pressure", "incompressibility",
                         "bed_friction", "side_wall_friction"]
    assert list(rhs) == ["gravity", "previous_velocity"]
    S = math.sqrt(2) * 0.4 * P / math.sqrt(0.5 + eps**2) + 2 * 0.5
    assert value(lhs["viscoplastic"]) == pytest.approx(S * 0.5 * AREA, rel=1e-10)
    assert value(lhs["inertia"]) == pytest.approx(RHO / DT * LX * LY**3 / 3, rel=1e-12)
    assert value(rhs["gravity"]) == pytest.approx(0.0, abs=1e-12)


def test_augmented_terms_are_the_named_terms(omega):
    """augmented_terms: optional wall and side-wall terms appear with their inputs."""
    msh, _, _, ds = omega
    f = vec(omega, lambda x, y: 1, lambda x, y: 0)
    p = scal(omega, lambda x, y: 1)
    zero = [[0.0, 0.0], [0.0, 0.0]]
    common = {"rho": const(omega, RHO), "dt": const(omega, DT),
              "body_force": const(omega, (0.0, -9.81)), "r": const(omega, 100.0), "u_old": f,
              "mesh_velocity": f, "sigma": const(omega, zero), "gamma": const(omega, zero),
              "trial": (f, p), "test": (f, p)}
    lhs, rhs = augmented.augmented_terms(**common)
    assert list(lhs) == ["inertia", "convection", "augmented_viscous", "pressure", "incompressibility"]
    assert list(rhs) == ["gravity", "previous_velocity", "multiplier_stress"]
    lhs, rhs = augmented.augmented_terms(**common, n=ufl.FacetNormal(msh), ds_friction=ds(BOTTOM),
                                         r_f=const(omega, 3.0), traction=f, slip=f,
                                         r_w=const(omega, 5.0), side_traction=f, side_slip=f)
    assert list(lhs)[-2:] == ["boundary_augmentation", "volume_augmentation"]
    assert list(rhs)[-2:] == ["boundary_multiplier", "volume_multiplier"]
    assert value(lhs["volume_augmentation"]) == pytest.approx(5.0 * AREA, rel=1e-12)
    assert value(rhs["boundary_multiplier"]) == pytest.approx((1 + 3.0) * LX, rel=1e-12)


def test_surface_tension_term_in_both_models_terms(omega):
    """"surface_tension" = −∫_Γf γ v·N ds, the last right-hand-side term of both models when
    the free surface (γ, ds) is given: on the top y = 0.2 (N = (0, 1)) with γ = x (P1) and
    v = (x + y, 2 + x), −∫_0^0.3 x (2 + x) dx = −(0.3² + 0.3³/3) = −0.099; absent otherwise."""
    msh, _, _, ds = omega
    gamma = fem.Function(compat.scalar_space(msh, 1))
    gamma.interpolate(lambda x: x[0])
    v = vec(omega, lambda x, y: x + y, lambda x, y: 2 + x)
    p = scal(omega, lambda x, y: 1)
    expected = -(LX**2 + LX**3 / 3)
    n = ufl.FacetNormal(msh)
    args = dict(rho=const(omega, RHO), dt=const(omega, DT), body_force=const(omega, (0.0, -9.81)),
                u_old=v, mesh_velocity=v, trial=(v, p), test=(v, p), n=n)
    _, rhs = picard_terms(DruckerPrager(0.5, 0.4), epsilon=1e-6, epsilon_friction=1e-6,
                          u_iter=v, p_iter=p, ds=ds, **args)
    assert "surface_tension" not in rhs
    _, rhs = picard_terms(DruckerPrager(0.5, 0.4), epsilon=1e-6, epsilon_friction=1e-6,
                          u_iter=v, p_iter=p, ds=ds, surface=(gamma, ds(TOP)), **args)
    assert list(rhs)[-1] == "surface_tension"
    assert value(rhs["surface_tension"]) == pytest.approx(expected, rel=1e-12)
    zero = [[0.0, 0.0], [0.0, 0.0]]
    _, rhs = augmented.augmented_terms(r=const(omega, 100.0), sigma=const(omega, zero),
                                       gamma=const(omega, zero), surface=(gamma, ds(TOP)), **args)
    assert list(rhs)[-1] == "surface_tension"
    assert value(rhs["surface_tension"]) == pytest.approx(expected, rel=1e-12)
