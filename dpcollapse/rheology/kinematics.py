"""Kinematic quantities shared by the constitutive laws and the weak forms, as UFL.

Norm convention of the project: |T| = √(T:T) (Frobenius). In simple shear u = (γ̇ y, 0),
D:D = γ̇²/2, so γ̇ = √2 |D|.
"""

from __future__ import annotations

import ufl

from dpcollapse.rheology.coordinates import PLANAR


def positive_part(x):
    """[x]_+ = max(x, 0) as UFL."""
    return ufl.conditional(ufl.gt(x, 0), x, 0)


def strain_rate(u):
    """D(u) = (∇u + ∇uᵀ)/2."""
    return ufl.sym(ufl.grad(u))


def frobenius_norm_sq(tensor):
    """|T|² = T:T."""
    return ufl.inner(tensor, tensor)


def regularized_secant(yield_stress, rate_viscosity, u, epsilon, cap=None, coordinates=PLANAR):
    """S = min(κ/√(|D(u)|² + ε²) + 2η, 2η_max) [Pa s]: the coefficient of D(v) in the Picard
    linearization of σ' = κ D/|D| + 2η D (no min when ``cap`` η_max is None); D(u) that of
    ``coordinates`` (``rheology.coordinates``: with the hoop rate u_r/r when axisymmetric)."""
    rate_sq = frobenius_norm_sq(coordinates.strain_rate(u))
    S = yield_stress / ufl.sqrt(rate_sq + epsilon**2) + 2.0 * rate_viscosity
    if cap is not None:
        S = ufl.min_value(S, 2.0 * cap)
    return S
