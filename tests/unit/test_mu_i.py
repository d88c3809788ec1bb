"""Unit tests of the μ(I) law, its well-posedness window and the Bagnold reference profile.

Norm convention: |D| = √(D:D) (Frobenius); simple shear u = (γ̇ y, 0) has γ̇ = √2 |D|.
"""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI
from scipy.integrate import trapezoid  # np.trapz: deprecated in numpy 2

from dpcollapse import compat
from dpcollapse.reference.bagnold import (
    bagnold_inertial_number,
    bagnold_mean_velocity,
    bagnold_shear_rate,
    bagnold_surface_velocity,
    bagnold_velocity,
)
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import PRESSURE_FLOOR, MuI
from dpcollapse.rheology.wellposedness import criterion, fraction_ill_posed, well_posed_window

# Gerris column-collapse parameters (seed 004), grains of 1 mm, ρ_s = 2500 kg/m³.
MU_S, MU_2, I0, D_GRAIN, RHO_S = 0.32, 0.60, 0.4, 1e-3, 2500.0


def _law(**kw):
    args = dict(mu_s=MU_S, mu_2=MU_2, I0=I0, grain_diameter=D_GRAIN, grain_density=RHO_S)
    args.update(kw)
    return MuI(**args)


class _Shear:
    """u = (γ̇ y, 0) on the unit square; p and ε are Constants (one compiled form per law/quantity)."""

    def __init__(self):
        self.msh = dmesh.create_unit_square(MPI.COMM_SELF, 2, 2)
        self.u = fem.Function(compat.vector_space(self.msh, 1))
        self.p = fem.Constant(self.msh, compat.ScalarType(1.0))
        self.eps = fem.Constant(self.msh, compat.ScalarType(1e-6))
        self._forms = {}

    def _form(self, law, what):
        key = (law, what)
        if key not in self._forms:
            if what == "tau":
                expr = law.deviatoric_stress(self.u, self.p, self.eps)[0, 1]
            elif what == "I":
                expr = law.inertial_number(self.u, self.p, self.eps)
            elif what == "S":
                expr = law.secant_viscosity(self.u, self.p, self.eps)
            self._forms[key] = fem.form(expr * ufl.dx)
        return self._forms[key]

    def __call__(self, law, what, gamma_dot, p, eps):
        """Mean over the unit square (area 1) of the quantity = its value (it is uniform)."""
        self.u.interpolate(lambda x: np.vstack([gamma_dot * x[1], 0 * x[0]]))
        self.p.value = p
        self.eps.value = eps
        return fem.assemble_scalar(self._form(law, what))


@pytest.fixture(scope="module")
def shear():
    return _Shear()


def _tau_expected(law, gamma_dot, p, eps):
    """Regularized simple-shear stress of the derivation (module docstring of mu_i)."""
    g_eps = math.sqrt(gamma_dot**2 + 2 * eps**2)
    sqrt_p = math.sqrt((max(p, 0.0) + PRESSURE_FLOOR) / law.grain_density)
    plastic = (law.cohesion + law.mu_s * max(p, 0.0)) * gamma_dot / g_eps
    rate = (law.mu_2 - law.mu_s) * max(p, 0.0) * gamma_dot / (g_eps + law.I0 * sqrt_p / law.grain_diameter)
    return plastic + rate


# ---------------------------------------------------------------- μ(I) by hand
def test_friction_by_hand():
    law = _law()
    assert law.friction(0.0) == pytest.approx(0.32, abs=1e-15)
    assert law.friction(0.4) == pytest.approx(0.32 + 0.28 / 2, rel=1e-14)  # I = I0: halfway
    assert law.friction(0.1) == pytest.approx(0.32 + 0.28 * 0.1 / 0.5, rel=1e-14)  # 0.376
    assert law.friction(1.2) == pytest.approx(0.32 + 0.28 / (0.4 / 1.2 + 1), rel=1e-14)  # 0.53
    assert law.friction(1e12) == pytest.approx(0.60, rel=1e-10)
    np.testing.assert_allclose(law.friction(np.array([0.0, 0.4])), [0.32, 0.46], rtol=1e-14)
    assert law.friction_derivative(0.1) == pytest.approx(0.28 * 0.4 / 0.5**2, rel=1e-14)
    with pytest.raises(ValueError):
        law.friction(-0.1)


def test_inertial_number_numpy():
    law = _law()
    # d γ̇ / √(p/ρ_s) = 1e-3 · 10 / √(1000/2500) = 0.01/0.632455...
    assert law.inertial_number_np(10.0, 1000.0) == pytest.approx(0.01 / math.sqrt(0.4), rel=1e-12)
    big = law.inertial_number_np(1.0, -50.0)
    assert math.isfinite(big) and big > 1e3


# ---------------------------------------------------------------- UFL, simple shear
@pytest.mark.parametrize("gamma_dot, p", [(0.5, 200.0), (10.0, 1000.0), (300.0, 50.0)])
def test_ufl_inertial_number_in_simple_shear(shear, gamma_dot, p):
    law = _law()
    I = shear(law, "I", gamma_dot, p, 1e-9)
    assert I == pytest.approx(D_GRAIN * gamma_dot / math.sqrt(p / RHO_S), rel=1e-10)


@pytest.mark.parametrize("cohesion", [0.0, 150.0])
@pytest.mark.parametrize("gamma_dot, p", [(0.05, 2500.0), (10.0, 1000.0), (300.0, 50.0)])
def test_simple_shear_stress_tends_to_mu_I_p(shear, cohesion, gamma_dot, p):
    """σ'_xy = regularized formula at finite ε, → κ0 + μ(I) p as ε → 0 (I = 5e-5, 0.016, 2.1)."""
    law = _law(cohesion=cohesion)
    for eps in (1e-1, 1e-3):
        assert shear(law, "tau", gamma_dot, p, eps) == pytest.approx(
            _tau_expected(law, gamma_dot, p, eps), rel=1e-12
        )
    I = D_GRAIN * gamma_dot / math.sqrt(p / RHO_S)
    tau = shear(law, "tau", gamma_dot, p, 1e-9)
    assert tau == pytest.approx(cohesion + law.friction(I) * p, rel=1e-10)
    # the rate part beyond Drucker–Prager's κ0 + μ_s p is resolved, even at I = 5e-5
    assert tau - cohesion - MU_S * p == pytest.approx((MU_2 - MU_S) * I / (I0 + I) * p, rel=1e-5)


def test_negative_pressure_is_finite_and_has_no_friction(shear):
    law = _law()
    for gamma_dot in (0.0, 1.0):
        for what in ("tau", "I", "S"):
            value = shear(law, what, gamma_dot, -1000.0, 1e-6)
            assert math.isfinite(value), (what, gamma_dot)
    assert shear(law, "tau", 1.0, -1000.0, 1e-6) == pytest.approx(
        0.0, abs=1e-9
    )  # round-off only (numpy 2: ~1e-15)
    assert shear(law, "S", 1.0, -1000.0, 1e-6) == pytest.approx(
        0.0, abs=1e-9
    )  # round-off only (numpy 2: ~1e-15)
    # at p = 0 exactly as well
    assert shear(law, "tau", 1.0, 0.0, 1e-6) == pytest.approx(
        0.0, abs=1e-9
    )  # round-off only (numpy 2: ~1e-15)
    # with cohesion only κ0 remains: τ = κ0 γ̇/√(γ̇²+2ε²)
    coh = _law(cohesion=80.0)
    assert shear(coh, "tau", 1.0, -1000.0, 1e-6) == pytest.approx(80.0, rel=1e-10)


def test_viscosity_cap(shear):
    """S = min(S_μI, 2η_max): a capped flow has σ'_xy = η_max γ̇ (Gerris η = min(η_max, μ p/(√2|D|)))."""
    eta_max = 10.0
    law = _law(viscosity_cap=eta_max)
    gamma_dot, p = 1.0, 1000.0  # uncapped τ ≈ 0.32·1000 ≫ η_max γ̇ = 10
    assert shear(law, "tau", gamma_dot, p, 1e-6) == pytest.approx(eta_max * gamma_dot, rel=1e-12)
    assert shear(law, "S", gamma_dot, p, 1e-6) == pytest.approx(2 * eta_max, rel=1e-12)
    # near rest the cap bounds the secant viscosity instead of √2 μ_s p/ε
    assert shear(law, "S", 0.0, p, 1e-8) == pytest.approx(2 * eta_max, rel=1e-12)
    # inactive cap: same stress as without it
    big = _law(viscosity_cap=1e9)
    assert shear(big, "tau", 10.0, p, 1e-6) == pytest.approx(_tau_expected(big, 10.0, p, 1e-6), rel=1e-12)


def test_same_interface_as_drucker_prager():
    for name in ("yield_stress", "secant_viscosity", "deviatoric_stress"):
        assert callable(getattr(MuI, name)) and callable(getattr(DruckerPrager, name))


def test_parameters_are_validated():
    with pytest.raises(ValueError, match="mu_s"):
        _law(mu_s=0.0)
    with pytest.raises(ValueError, match="mu_2"):
        _law(mu_2=0.3)
    with pytest.raises(ValueError, match="mu_2"):
        _law(mu_2=MU_S)
    with pytest.raises(ValueError, match="I0"):
        _law(I0=0.0)
    with pytest.raises(ValueError, match="grain_diameter"):
        _law(grain_diameter=-1e-3)
    with pytest.raises(ValueError, match="grain_density"):
        _law(grain_density=0.0)
    with pytest.raises(ValueError, match="cohesion"):
        _law(cohesion=-1.0)
    with pytest.raises(ValueError, match="viscosity_cap"):
        _law(viscosity_cap=0.0)
    with pytest.raises(ValueError, match="I0"):
        _law(I0=float("nan"))
    _law(cohesion=0.0, viscosity_cap=None)  # valid


# ---------------------------------------------------------------- well-posedness
def test_criterion_by_hand():
    law = _law()  # 0.32, 0.60, 0.4
    I = 0.4
    mu = 0.32 + 0.28 * 0.4 / (0.4 + 0.4)  # 0.46
    dmu = 0.28 * 0.4 / (0.4 + 0.4) ** 2  # 0.175
    nu = I * dmu / mu  # 0.152174
    C = 4 * nu**2 - 4 * nu + mu**2 * (1 - nu / 2) ** 2  # ≈ −0.33544
    assert C == pytest.approx(-0.33544, abs=1e-5)
    assert criterion(law, I) == pytest.approx(C, rel=1e-12)
    assert criterion(law, 0.0) == pytest.approx(0.32**2, rel=1e-12)  # static: ill posed


@pytest.mark.parametrize(
    "mu_s, mu_2, i0, lo, hi",
    [(0.32, 0.60, 0.4, 0.0136, 1.81), (0.3819, 0.6435, 0.279, 0.0194, 0.852)],
)
def test_well_posed_windows(mu_s, mu_2, i0, lo, hi):
    law = MuI(mu_s, mu_2, i0, D_GRAIN, RHO_S)
    I_min, I_max = well_posed_window(law)
    assert I_min == pytest.approx(lo, rel=1e-2)
    assert I_max == pytest.approx(hi, rel=1e-2)
    assert criterion(law, I_min) == pytest.approx(0.0, abs=1e-10)
    assert criterion(law, math.sqrt(I_min * I_max)) < 0
    assert criterion(law, 0.5 * I_min) > 0 and criterion(law, 2 * I_max) > 0


def test_empty_window_and_fraction():
    assert all(math.isnan(x) for x in well_posed_window(MuI(2.0, 3.0, 0.3, D_GRAIN, RHO_S)))
    law = _law()
    I = np.array([0.0, 1e-3, 0.1, 0.5, 1.0, 5.0])  # ill, ill, ok, ok, ok, ill
    assert fraction_ill_posed(law, I) == pytest.approx(3 / 6)
    w = np.array([1.0, 1.0, 2.0, 2.0, 2.0, 2.0])
    assert fraction_ill_posed(law, I, w) == pytest.approx(4 / 10)
    with pytest.raises(ValueError):
        fraction_ill_posed(law, I, np.zeros_like(I))
    with pytest.raises(ValueError):
        fraction_ill_posed(law, [])


# ---------------------------------------------------------------- Bagnold
BASILISK = dict(mu_s=0.38, mu_2=0.64, I0=0.3, grain_diameter=0.04, grain_density=1.0)


def test_bagnold_basilisk_numbers():
    """θ = 0.43, d = 0.04, μ_s = 0.38, Δμ = 0.26, I0 = 0.3, g = h = 1, ρ = ρ_s.

    Analytic u_s = (2/3)(I_θ/d)√(g cosθ) = 2.06631 = the Basilisk run's value; the README's
    3.0995 is (I_θ/d)√(g cosθ) without the 2/3."""
    law = MuI(**BASILISK)
    assert bagnold_inertial_number(law, 0.43) == pytest.approx(0.13004, rel=1e-4)
    us = bagnold_surface_velocity(law, 0.43, 1.0, density=1.0, gravity=1.0)
    assert us == pytest.approx(2.06631, rel=1e-5)
    # the README's 3.0995, from I_θ alone (independent of bagnold_surface_velocity)
    I_theta = bagnold_inertial_number(law, 0.43)
    assert I_theta / BASILISK["grain_diameter"] * math.sqrt(math.cos(0.43)) == pytest.approx(3.0995, rel=1e-4)
    assert bagnold_mean_velocity(law, 0.43, 1.0, 1.0, 1.0) / us == pytest.approx(0.6, rel=1e-14)


def test_bagnold_profile_consistency():
    law = _law()
    theta, h, rho, g = math.atan(0.45), 0.05, 1500.0, 9.81
    y = np.linspace(0.0, h, 2001)
    u = bagnold_velocity(law, theta, h, y, rho, g)
    assert abs(u[0]) <= 1e-12 * u.max()  # zero up to round-off (numpy 2: 9.3e-16)
    # README form for ρ = ρ_s
    It = bagnold_inertial_number(law, theta)
    readme = (2 / 3) * (It / D_GRAIN) * math.sqrt(g * math.cos(theta)) * (h**1.5 - (h - y) ** 1.5)
    np.testing.assert_allclose(bagnold_velocity(law, theta, h, y, RHO_S, g), readme, rtol=1e-13)
    # density scaling √(ρ/ρ_s)
    np.testing.assert_allclose(u, readme * math.sqrt(rho / RHO_S), rtol=1e-13)
    # trapezoidal depth average → 3/5 of the surface velocity
    assert trapezoid(u, y) / h == pytest.approx(0.6 * u[-1], rel=1e-5)
    # the profile is μ(I) = tanθ everywhere: I from γ̇ and p = ρ g cosθ (h − y)
    yi = y[:-1]
    gd = bagnold_shear_rate(law, theta, h, yi, rho, g)
    p = rho * g * math.cos(theta) * (h - yi)
    np.testing.assert_allclose(law.friction(law.inertial_number_np(gd, p)), math.tan(theta), rtol=1e-9)


def test_bagnold_rejects_slopes_outside_window():
    law = _law()
    with pytest.raises(ValueError, match="tan"):
        bagnold_inertial_number(law, math.atan(0.30))  # below μ_s: no flow
    with pytest.raises(ValueError, match="tan"):
        bagnold_inertial_number(law, math.atan(0.61))  # above μ_2: accelerates
    with pytest.raises(ValueError):
        bagnold_velocity(law, math.atan(0.45), 1.0, 1.5, RHO_S)
    with pytest.raises(ValueError):
        bagnold_surface_velocity(law, math.atan(0.45), -1.0, RHO_S)
    with pytest.raises(ValueError, match="cohesion"):
        bagnold_inertial_number(_law(cohesion=10.0), math.atan(0.45))
