"""Kinematic quantities shared by the constitutive laws and the weak forms, as UFL.

Norm convention of the project: |T| = √(T:T) (Frobenius). In simple shear u = (γ̇ y, 0),
D:D = γ̇²/2, so γ̇ = √2 |D|.
"""

from __future__ import annotations

import ufl


def positive_part(x):
    """[x]_+ = max(x, 0) as UFL."""
    return ufl.conditional(ufl.gt(x, 0), x, 0)


def strain_rate(u):
    """D(u) = (∇u + ∇uᵀ)/2."""
    return ufl.sym(ufl.grad(u))


def frobenius_norm_sq(tensor):
    """|T|² = T:T."""
    return ufl.inner(tensor, tensor)
