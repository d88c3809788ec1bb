"""Coulomb friction on the bed and the left wall, regularized (seeds 000/001).

With no penetration u·n = 0 imposed exactly, the tangential traction on a wall of
friction coefficient μ is, in its Picard-linearized regularized form::

    ∫_Γ μ [pᵏ − σ'_nn(uᵏ, pᵏ)]_+ / √(|u_Tᵏ|² + ε_f²) · u_T · v_T ds

where u_T = u − (u·n) n and σ'_nn = n·σ'n is the normal deviatoric stress (bounded by
κ + 2η|D| even when the regularized viscosity is huge).
"""

from __future__ import annotations

import ufl

from dpcollapse.rheology.kinematics import positive_part


def tangential(u, n):
    """u_T = u − (u·n) n."""
    return u - ufl.dot(u, n) * n


def normal_pressure(p, deviatoric_stress, n):
    """[p − σ'_nn]_+: the compressive normal stress that friction acts on [Pa]."""
    return positive_part(p - ufl.dot(n, ufl.dot(deviatoric_stress, n)))


def coulomb_friction(mu, normal_stress, u_iter, eps_f, u, v, n, ds):
    """∫ μ [p−σ'_nn]_+ u_T·v_T / √(|u_Tᵏ|²+ε_f²) ds on the measure ``ds``."""
    ut_k = tangential(u_iter, n)
    coefficient = mu * normal_stress / ufl.sqrt(ufl.inner(ut_k, ut_k) + eps_f**2)
    return coefficient * ufl.inner(tangential(u, n), tangential(v, n)) * ds


def side_wall_friction(width, mu_w, p_iter, u_iter, eps_f, u, v, dx=ufl.dx):
    """Width-averaged friction of the two side walls of a channel of width w (seed 002)::

        (2/w) ∫_Ω μ_w [pᵏ]_+ u·v / √(|uᵏ|² + ε_f²) dx

    (the walls' normal stress is σ_zz = −p; the regularization is that of the bed friction).
    """
    coefficient = 2.0 / width * mu_w * positive_part(p_iter) / ufl.sqrt(ufl.inner(u_iter, u_iter) + eps_f**2)
    return coefficient * ufl.inner(u, v) * dx
