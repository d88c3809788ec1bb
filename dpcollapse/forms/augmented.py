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

On a slanted solid side (no velocity component to carry u·n = 0) the condition is imposed by
Nitsche's method with the step's operator stress r D(u) − p I ("<wall>_no_penetration",
``forms.no_penetration``), and the normal part of the explicit stress σ' − r γ̇ that the
integration by parts leaves on the side goes to the right-hand side::

  + ∫_Γ n·(σ' − r γ̇)n (v·n) ds                          "<wall>_normal_multiplier"
"""

from __future__ import annotations

import ufl

from dpcollapse.forms import momentum, no_penetration
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


def normal_multiplier(sigma, gamma, r, v, n, ds):
    """∫_Γ n·(σ' − r γ̇)n (v·n) ds on a slanted side (right-hand side; with Nitsche's u·n = 0)."""
    return ufl.dot(n, ufl.dot(sigma - r * gamma, n)) * ufl.dot(v, n) * ds


def volume_augmentation(r_w, u, v, dx=ufl.dx):
    """∫ r_w u·v dx: penalty of the side-wall slip multiplier."""
    return r_w * ufl.inner(u, v) * dx


def volume_multiplier(traction, slip, r_w, v, dx=ufl.dx):
    """∫ (σ_w + r_w δ_w)·v dx (right-hand side)."""
    return ufl.inner(traction + r_w * slip, v) * dx


def augmented_terms(*, rho, dt, body_force, r, u_old, mesh_velocity, sigma, gamma, trial, test,
                    n=None, ds_friction=None, r_f=None, traction=None, slip=None,
                    r_w=None, side_traction=None, side_slip=None, weak_walls=()) -> tuple[dict, dict]:
    """(lhs, rhs): the named terms of step 1 (the module docstring's equation).

    lhs: "inertia", "convection" (by uⁿ − w), "augmented_viscous", "pressure",
    "incompressibility", and "boundary_augmentation" when ``ds_friction`` (the friction
    walls) is given, "volume_augmentation" when ``r_w`` is given;
    rhs: "gravity", "previous_velocity", "multiplier_stress", and "boundary_multiplier",
    "volume_multiplier" likewise; for each (name, ds) of ``weak_walls`` (slanted solid
    sides) "<name>" on the left and "<name>" with "_no_penetration" replaced by
    "_normal_multiplier" on the right. Σ lhs = Σ rhs in the order of the dictionaries.
    """
    (u, p), (v, q) = trial, test
    lhs = {
        "inertia": momentum.inertia(rho, dt, u, v),
        "convection": momentum.convection(rho, u_old, mesh_velocity, u, v),
        "augmented_viscous": augmented_viscous(r, u, v),
        "pressure": momentum.pressure(p, v),
        "incompressibility": momentum.incompressibility(q, u),
    }
    rhs = {
        "gravity": momentum.gravity(rho, body_force, v),
        "previous_velocity": momentum.previous_velocity(rho, dt, u_old, v),
        "multiplier_stress": multiplier_stress(sigma, gamma, r, v),
    }
    if ds_friction is not None:
        lhs["boundary_augmentation"] = boundary_augmentation(r_f, u, v, n, ds_friction)
        rhs["boundary_multiplier"] = boundary_multiplier(traction, slip, r_f, v, n, ds_friction)
    if r_w is not None:
        lhs["volume_augmentation"] = volume_augmentation(r_w, u, v)
        rhs["volume_multiplier"] = volume_multiplier(side_traction, side_slip, r_w, v)
    for name, ds_wall in weak_walls:
        lhs[name] = no_penetration.nitsche_no_penetration(r, u, p, v, q, n, ds_wall)
        rhs[name.replace("_no_penetration", "_normal_multiplier")] = normal_multiplier(
            sigma, gamma, r, v, n, ds_wall)
    return lhs, rhs
