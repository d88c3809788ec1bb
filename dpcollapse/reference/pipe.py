r"""Exact steady flows in a circular pipe (axisymmetric coordinates, ``geometry.symmetry``).

A pipe of radius R, axis along z, driven by a uniform body force ρ f_z = −G (G > 0: the
flow goes towards −z, as under gravity G = ρ g), with no slip at r = R and the velocity
u = (0, u_z(r)) independent of z. With the shear stress τ = σ'_rz the z-momentum balance

    (1/r) d(r τ)/dr = G      ⇒   τ(r) = G r / 2                       (τ finite on the axis)

holds for any law. Newtonian (τ = η du_z/dr; Hagen–Poiseuille)::

    u_z(r) = −G (R² − r²) / (4η)

Bingham (the project's Drucker–Prager law with μ_s = 0 and cohesion τ_y: κ = √2 τ_y with
the Frobenius norm |D| = √(D:D); in this flow D_rz = u_z'/2, |D| = |u_z'|/√2, so
σ'_rz = η u_z' + τ_y sign(u_z') where the material flows; Buckingham–Reiner)::

    plug radius  r_p = 2 τ_y / G      (|τ| ≤ τ_y for r ≤ r_p: rigid, u_z' = 0)
    u_z(r) = −[G (R² − r²)/4 − τ_y (R − r)] / η     for r_p ≤ r ≤ R
    u_z(r) = u_z(r_p)                                for 0 ≤ r ≤ r_p

(for r_p ≥ R the whole pipe is rigid and at rest). Each branch is a quadratic in r, so on a
mesh with a line of nodes at r = r_p the profile lies in P2.
"""

from __future__ import annotations

import numpy as np


def poiseuille_pipe(r, radius: float, driving: float, viscosity: float) -> np.ndarray:
    """u_z(r) = −G (R² − r²)/(4η) [m/s] of the Newtonian pipe (G = ``driving`` [Pa/m])."""
    r = np.asarray(r, dtype=float)
    return -driving * (radius**2 - r**2) / (4.0 * viscosity)


def plug_radius(driving: float, yield_stress: float) -> float:
    """r_p = 2 τ_y / G [m]: inside it the Bingham material moves as a rigid plug."""
    return 2.0 * yield_stress / driving


def bingham_pipe(r, radius: float, driving: float, viscosity: float,
                 yield_stress: float) -> np.ndarray:
    """u_z(r) of the Bingham pipe (the module docstring) [m/s]; zero everywhere when the
    plug fills the pipe (r_p ≥ R)."""
    r = np.asarray(r, dtype=float)
    rp = plug_radius(driving, yield_stress)
    if rp >= radius:
        return np.zeros_like(r)
    rr = np.maximum(r, rp)
    return -(driving * (radius**2 - rr**2) / 4.0 - yield_stress * (radius - rr)) / viscosity
