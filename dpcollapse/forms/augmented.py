"""UFL terms of step 1 of the augmented Lagrangian (decomposition–coordination) method.

Seed 002, eq. (32) and its boundary conditions: with the multipliers of the previous
iteration — deviatoric stress σ', strain-rate multiplier γ̇ (DG tensors), tangential
traction σ_T and slip multiplier δ on the friction walls — step 1 solves the *linear*
problem, for every test pair (v, q)::

    ∫ ρ (u − uⁿ)/Δt · v + ∫ ρ ((uⁿ − w)·∇) u · v        (inertia, convection by uⁿ)
  + ∫ r D(u):D(v)                                       "augmented_viscous"
  + ∫_Γ r_f u_T·v_T ds                                  "boundary_augmentation"
  − ∫ p div v − ∫ q div u
  = ∫ ρ f·v + ∫ ρ uⁿ/Δt·v
  − ∫ (σ' − r γ̇):D(v)                                   "multiplier_stress"
  + ∫_Γ (σ_T + r_f δ)·v_T ds                            "boundary_multiplier"

The matrix holds only ρ/Δt, uⁿ − w and the penalties r, r_f: it is fixed during a time
step, so one LU factorization serves every iteration. Width-averaged side-wall friction
(2/w) μ_w [p]_+ u/|u| is a Coulomb law in the volume and gets the same treatment with a
volume slip multiplier δ_w, traction σ_w and penalty r_w ("volume_augmentation",
"volume_multiplier").
"""

from __future__ import annotations

import ufl

from dpcollapse.forms.friction import tangential
from dpcollapse.rheology.kinematics import strain_rate


def augmented_viscous(r, u, v, dx=ufl.dx):
    """∫ r D(u):D(v) dx: the augmentation term, the only 'viscosity' of step 1."""
    return r * ufl.inner(strain_rate(u), strain_rate(v)) * dx


def multiplier_stress(sigma, gamma, r, v, dx=ufl.dx):
    """−∫ (σ' − r γ̇):D(v) dx (right-hand side)."""
    return -ufl.inner(sigma - r * gamma, strain_rate(v)) * dx


def boundary_augmentation(r_f, u, v, n, ds):
    """∫_Γ r_f u_T·v_T ds on a friction wall (no penetration is imposed strongly)."""
    return r_f * ufl.inner(tangential(u, n), tangential(v, n)) * ds


def boundary_multiplier(traction, slip, r_f, v, n, ds):
    """∫_Γ (σ_T + r_f δ)·v_T ds (right-hand side)."""
    return ufl.inner(tangential(traction + r_f * slip, n), tangential(v, n)) * ds


def volume_augmentation(r_w, u, v, dx=ufl.dx):
    """∫ r_w u·v dx: penalty of the side-wall slip multiplier."""
    return r_w * ufl.inner(u, v) * dx


def volume_multiplier(traction, slip, r_w, v, dx=ufl.dx):
    """∫ (σ_w + r_w δ_w)·v dx (right-hand side)."""
    return ufl.inner(traction + r_w * slip, v) * dx
