"""The residual of one time step of the regularized flow and its exact Jacobian (Newton).

The residual is the Picard system of ``forms.picard`` with the frozen coefficients put back
to the unknowns, i.e. the same named terms with trial = iterate = U = (u, p)::

    F(U; v, q) = ∫ ρ (u − uⁿ)/Δt · v                                   "inertia" − "previous_velocity"
               + ∫ ρ ((u − w)·∇) u · v                                  "convection"
               + ∫ S(u, p) D(u):D(v)                                    "viscoplastic"
               − ∫ p div v − ∫ q div u                                  "pressure", "incompressibility"
               + ∫_Γ μ [p − σ'_nn(u, p)]_+ u_T·v_T/√(|u_T|² + ε_f²) ds  "<wall>_friction"
               + (2/w) ∫ μ_w [p]_+ u·v/√(|u|² + ε_f²)                  "side_wall_friction"
               − ∫ ρ f·v                                                "gravity"

with S(u, p) = κ(p)/|D(u)|_ε + 2η(|D(u)|, p) the law's secant viscosity. A fixed point of
Picard is a zero of F (same physics, same discretization). The Jacobian
J = ∂F/∂U [δU] is ``ufl.derivative``: it holds, besides the Picard matrix,
the derivative of S in D (the tangent −κ (D:δD) D/|D|_ε³ and μ(I)'s rate term), in p
(κ'(p) = √2 μ_s H(p) and ∂η/∂p of μ(I)), the convection (δu·∇)u, and the friction's
derivatives in u_T, in p and in σ'_nn(u, p). It is not symmetric.
"""

from __future__ import annotations

import ufl

from dpcollapse.forms.picard import picard_terms


def residual_terms(law, *, state, test, **picard_arguments) -> dict:
    """The named terms of F(U; V) (UFL linear forms in the test pair), F = Σ terms.

    state: (u, p) = ``ufl.split(U)``; the other arguments are those of
    :func:`~dpcollapse.forms.picard.picard_terms` (without trial, u_iter, p_iter).
    """
    u, p = state
    lhs, rhs = picard_terms(law, u_iter=u, p_iter=p, trial=(u, p), test=test, **picard_arguments)
    terms = dict(lhs)
    for name, form in rhs.items():
        terms[name] = -form
    return terms


def with_fixed_quadrature(form):
    """``form`` with the quadrature degree UFL estimates for it written into every integral
    that has none: the largest estimate over the integrals of one kind and subdomain, as
    the form compiler would take for their sum (so the residual is integrated as the Picard
    system is). Its Jacobian then uses the same rule; left to its own estimate, the
    Jacobian's integrand gets a different degree and is not the derivative of the
    integrated residual (measured: a constant 0.4 % mismatch against central differences)."""
    from ufl.algorithms.apply_algebra_lowering import apply_algebra_lowering
    from ufl.algorithms.apply_derivatives import apply_derivatives
    from ufl.algorithms.estimate_degrees import estimate_total_polynomial_degree

    degrees: dict = {}
    for itg in form.integrals():
        if "quadrature_degree" not in itg.metadata():
            integrand = apply_derivatives(apply_algebra_lowering(itg.integrand()))
            key = (itg.integral_type(), itg.subdomain_id())
            degrees[key] = max(degrees.get(key, 0), estimate_total_polynomial_degree(integrand, 1))
    fixed = []
    for itg in form.integrals():
        if "quadrature_degree" not in itg.metadata():
            degree = degrees[(itg.integral_type(), itg.subdomain_id())]
            itg = itg.reconstruct(metadata={**itg.metadata(), "quadrature_degree": degree})
        fixed.append(itg)
    return ufl.Form(fixed)


def jacobian(residual, U, dU):
    """J(U)[δU, V] = d/dτ F(U + τ δU; V) at τ = 0 (``ufl.derivative``; δU a TrialFunction;
    give F with its quadrature fixed, ``with_fixed_quadrature``)."""
    return ufl.derivative(residual, U, dU)
