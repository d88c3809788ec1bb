"""The named terms of one Picard iteration of the regularized flow (seed 000).

For (u, p) = (u^{n+1,k+1}, p^{n+1,k+1}) and every test pair (v, q)::

    lhs:  "inertia"            ∫ ρ u/Δt · v
          "convection"         ∫ ρ ((uᵏ − w)·∇) u · v
          "viscoplastic"       ∫ S(uᵏ, pᵏ) D(u):D(v),   S = κ(pᵏ)/|D(uᵏ)|_ε + 2η (the law's secant viscosity)
          "pressure"           −∫ p div v
          "incompressibility"  −∫ q div u
          "<wall>_friction"    ∫_Γ μ [pᵏ − σ'_nn]_+ u_T·v_T/√(|u_Tᵏ|² + ε_f²) ds   (each Coulomb wall)
          "side_wall_friction" (2/w) ∫ μ_w [pᵏ]_+ u·v/√(|uᵏ|² + ε_f²)            (channel of width w)
          "<wall>_no_penetration"  Nitsche's u·n = 0 on a slanted side, with S (forms.no_penetration)
    rhs:  "gravity"            ∫ ρ f·v
          "previous_velocity"  ∫ ρ uⁿ/Δt · v
          "surface_tension"    −∫_{Γ_f} γ v·N ds   (seed 000's local surface tension, when on)

With ``convection="lagged"`` the convection is taken wholly at the iterate,
rhs "convection" −∫ ρ ((uᵏ − w)·∇) uᵏ · v, instead of the lhs term: the fixed point (the
discrete equations at convergence) is the same, and the matrix left is symmetric — the
only unsymmetric term of the lhs is the convection (the friction, side-wall and Nitsche
terms are symmetric) — so it can be factorized as LDLᵀ at about half the cost of LU.

With ``coordinates`` axisymmetric (``rheology.coordinates``) every integral is weighted by
2πr (dx and ds), D has the hoop rate u_r/r and div u = ∂_r u_r + u_r/r + ∂_z u_z; the walls'
σ'_nn is the (r, z) block's. Planar, the forms are those of before, unchanged.

The system is Σ lhs = Σ rhs, summed in the order of the dictionaries. Each term is the
pure function of ``forms.momentum`` or ``forms.friction`` that documents its integral.
"""

from __future__ import annotations

import ufl

from dpcollapse.forms import friction, momentum, no_penetration
from dpcollapse.forms.surface_tension import surface_tension
from dpcollapse.rheology.coordinates import PLANAR


def picard_terms(law, *, rho, dt, body_force, epsilon, epsilon_friction, u_iter, p_iter, u_old,
                 mesh_velocity, trial, test, n, dx=ufl.dx, ds=None, friction_walls=(),
                 side_walls=None, weak_walls=(), surface=None,
                 convection: str = "implicit", p_walls=None,
                 coordinates=PLANAR) -> tuple[dict, dict]:
    """(lhs, rhs): the named bilinear and linear terms (UFL forms) of one Picard iteration.

    law: a :class:`~dpcollapse.rheology.base.Rheology`; trial = (u, p), test = (v, q);
    friction_walls: (name, μ, facet tag) of each Coulomb wall, integrated on ``ds(tag)``;
    side_walls: (w, μ_w) for width-averaged side-wall friction, or None;
    weak_walls: (term name, facet tag) of each slanted solid side (Nitsche's u·n = 0);
    surface: (γ, ds over the free surface) of the local surface tension, or None;
    convection: "implicit" (lhs, linearized at uᵏ) or "lagged" (rhs, at uᵏ: symmetric lhs);
    p_walls: the pressure in the walls' normal stress [p − σ'_nn]_+ and the side walls'
    friction (None: ``p_iter``; the two-phase model's cut cells read ``p_iter`` at their
    centroid, the walls at the wall);
    coordinates: ``rheology.coordinates.PLANAR`` or ``AXISYMMETRIC`` (the measures 2πr dx,
    2πr ds, D and div of (r, z)).
    """
    (u, p), (v, q) = trial, test
    # planar: the measures themselves (the forms of before); axisymmetric: times 2πr
    mesh = ufl.domain.extract_unique_domain(v)
    dx_plain = coordinates.measure(ufl.dx, mesh)
    dx = coordinates.measure(dx, mesh)
    if ds is not None:
        ds = coordinates.measure(ds, mesh)
    secant = law.secant_viscosity(u_iter, p_iter, epsilon)
    if convection not in ("implicit", "lagged"):
        raise ValueError(f"convection = {convection!r}: must be 'implicit' or 'lagged'")
    lhs = {
        "inertia": momentum.inertia(rho, dt, u, v, dx_plain),
        **({"convection": momentum.convection(rho, u_iter, mesh_velocity, u, v, dx)}
           if convection == "implicit" else {}),
        "viscoplastic": momentum.viscoplastic(secant, u, v, dx, coordinates),
        "pressure": momentum.pressure(p, v, dx_plain, coordinates),
        "incompressibility": momentum.incompressibility(q, u, dx_plain, coordinates),
    }
    p_walls = p_iter if p_walls is None else p_walls
    if friction_walls:
        stress = coordinates.in_plane(law.deviatoric_stress(u_iter, p_iter, epsilon))
        normal_stress = friction.normal_pressure(p_walls, stress, n)
        for name, mu, tag in friction_walls:
            lhs[name] = friction.coulomb_friction(mu, normal_stress, u_iter, epsilon_friction, u, v, n,
                                                  ds(tag))
    if side_walls is not None:
        width, mu_side = side_walls
        lhs["side_wall_friction"] = friction.side_wall_friction(width, mu_side, p_walls, u_iter,
                                                                epsilon_friction, u, v, dx)
    for name, tag in weak_walls:
        lhs[name] = no_penetration.nitsche_no_penetration(secant, u, p, v, q, n, ds(tag))
    rhs = {
        "gravity": momentum.gravity(rho, body_force, v, dx_plain),
        "previous_velocity": momentum.previous_velocity(rho, dt, u_old, v, dx_plain),
    }
    if convection == "lagged":
        rhs["convection"] = -momentum.convection(rho, u_iter, mesh_velocity, u_iter, v, dx)
    if surface is not None:
        gamma, ds_surface = surface
        rhs["surface_tension"] = surface_tension(gamma, v, n, coordinates.measure(ds_surface, mesh))
    return lhs, rhs
