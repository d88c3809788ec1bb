"""UFL terms of the momentum and mass balance on the current (moving) domain Ω^{n+1}.

One Picard iteration of seed 000 solves, for (u, p) = (u^{n+1,k+1}, p^{n+1,k+1}) and every
test pair (v, q) in V × M::

    ∫ ρ (u − uⁿ)/Δt · v                      "inertia"
  + ∫ ρ ((uᵏ − w)·∇) u · v                    "convection"  (ALE: convected by u − w)
  + ∫ (2η + κ(pᵏ)/√(|D(uᵏ)|²+ε²)) D(u):D(v)   "viscoplastic"
  − ∫ p div v − ∫ q div u                     "pressure", "incompressibility"
  + Coulomb friction on bed and wall            (forms.friction)
  = ∫ ρ f · v                                  "gravity", f = g (sin θ, −cos θ)

Each term is a pure function returning a UFL form so it can be assembled and tested alone.
The cell measure ``dx`` is an argument (default ``ufl.dx``) so that the solver can fix the
quadrature degree of the nonlinear terms (``numerics.quadrature_degree``). In axisymmetric
coordinates (``geometry.symmetry``) ``dx`` is the weighted measure 2πr dx and the terms with D
and div take ``coordinates`` (``rheology.coordinates``): D(u) with the hoop rate u_r/r and
∇·u = ∂_r u_r + u_r/r + ∂_z u_z.
"""

from __future__ import annotations

import ufl

from dpcollapse.rheology.coordinates import PLANAR


def inertia(rho, dt, u, v, dx=ufl.dx):
    """∫ ρ u/Δt · v dx: the implicit half of ∫ ρ (u − uⁿ)/Δt · v (bilinear)."""
    return rho / dt * ufl.inner(u, v) * dx


def previous_velocity(rho, dt, u_old, v, dx=ufl.dx):
    """∫ ρ uⁿ/Δt · v dx: the explicit half of the time derivative (right-hand side)."""
    return rho / dt * ufl.inner(u_old, v) * dx


def convection(rho, u_iter, w, u, v, dx=ufl.dx):
    """∫ ρ ((uᵏ − w)·∇) u · v dx, the ALE convective derivative linearized at uᵏ."""
    return rho * ufl.inner(ufl.grad(u) * (u_iter - w), v) * dx


def viscoplastic(secant_viscosity, u, v, dx=ufl.dx, coordinates=PLANAR):
    """∫ ν_eff D(u):D(v) dx with ν_eff = 2η + κ/√(|D(uᵏ)|²+ε²) frozen at the iterate."""
    D = coordinates.strain_rate
    return secant_viscosity * ufl.inner(D(u), D(v)) * dx


def pressure(p, v, dx=ufl.dx, coordinates=PLANAR):
    """−∫ p div v dx."""
    return -p * coordinates.divergence(v) * dx


def incompressibility(q, u, dx=ufl.dx, coordinates=PLANAR):
    """−∫ q div u dx (sign chosen so the saddle-point matrix is symmetric)."""
    return -q * coordinates.divergence(u) * dx


def gravity(rho, body_force, v, dx=ufl.dx):
    """∫ ρ f · v dx."""
    return rho * ufl.inner(body_force, v) * dx
