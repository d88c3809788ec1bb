"""Variable-step BDF2 on a moving mesh: its coefficients, the extrapolations, the error estimate.

With steps Δt = t^{n+1} − tⁿ and Δt' = tⁿ − t^{n−1}, r = Δt/Δt', the time derivative at
t^{n+1} of a nodal value y (along the node's trajectory: the ALE derivative) is

    ẏ^{n+1} ≈ (α₀ y^{n+1} − α₁ yⁿ + α₂ y^{n−1})/Δt,
    α₀ = (1 + 2r)/(1 + r),  α₁ = 1 + r,  α₂ = r²/(1 + r)        (BDF1: α = (1, 1, 0)),

i.e. BDF1 with the effective step Δt/α₀ and the effective old value
ŷ = (α₁ yⁿ − α₂ y^{n−1})/α₀: the momentum forms of BDF1 are reused unchanged.
Second-order mesh update: the nodes move by Δt w(u*), w the mesh velocity of the
midpoint velocity extrapolated from the last two steps,

    u* = uⁿ + (r/2)(uⁿ − u^{n−1})   (= u(tⁿ + Δt/2) + O(Δt²)).

Local error estimate (Milne's device): the BDF2 value is compared with the quadratic
extrapolation y^P of (y^{n−2}, y^{n−1}, yⁿ); for y''' constant both errors are exact
multiples of y''' (``error_constants``), so that the error of the BDF2 step is

    e ≈ C/(C_P − C) (y^{n+1} − y^P),  C, C_P the errors of BDF2 and of the predictor.
"""

from __future__ import annotations

import numpy as np


def bdf2_coefficients(dt: float, dt_previous: float | None) -> tuple[float, float, float]:
    """(α₀, α₁, α₂) of the variable-step BDF2 derivative (BDF1 (1, 1, 0) without a previous
    step)."""
    if dt_previous is None:
        return 1.0, 1.0, 0.0
    r = dt / dt_previous
    return (1 + 2 * r) / (1 + r), 1 + r, r * r / (1 + r)


def midpoint_weights(dt: float, dt_previous: float | None) -> tuple[float, float]:
    """(a, b) of u* = a uⁿ + b u^{n−1} ≈ u(tⁿ + Δt/2); (1, 0) without a previous step."""
    if dt_previous is None:
        return 1.0, 0.0
    r = dt / dt_previous
    return 1 + r / 2, -r / 2


def predictor_weights(dt: float, dt_previous: float, dt_before: float) -> np.ndarray:
    """Weights (of yⁿ, y^{n−1}, y^{n−2}) of the quadratic extrapolation to t^{n+1}."""
    t = np.array([0.0, -dt_previous, -dt_previous - dt_before])   # tⁿ, t^{n−1}, t^{n−2}
    x = dt
    w = np.empty(3)
    for i in range(3):
        others = [t[j] for j in range(3) if j != i]
        w[i] = np.prod([(x - tj) / (t[i] - tj) for tj in others])
    return w


def error_constants(dt: float, dt_previous: float, dt_before: float) -> tuple[float, float]:
    """(C, C_P): the local errors y(t^{n+1}) − y^{n+1} of the BDF2 step and of the quadratic
    predictor for y = t³/6 (y''' = 1), the past values exact."""
    def y(t):
        return t ** 3 / 6

    def dy(t):
        return t ** 2 / 2

    tn1, tn, tm1, tm2 = dt, 0.0, -dt_previous, -dt_previous - dt_before
    a0, a1, a2 = bdf2_coefficients(dt, dt_previous)
    # α₀ y^{n+1} − α₁ yⁿ + α₂ y^{n−1} = Δt y'(t^{n+1})  →  the computed y^{n+1}
    computed = (dt * dy(tn1) + a1 * y(tn) - a2 * y(tm1)) / a0
    predicted = predictor_weights(dt, dt_previous, dt_before) @ np.array([y(tn), y(tm1), y(tm2)])
    return y(tn1) - computed, y(tn1) - predicted


def milne_factor(dt: float, dt_previous: float, dt_before: float) -> float:
    """C/(C_P − C): the local error of the BDF2 step per unit of (y^{n+1} − y^P)."""
    c, c_p = error_constants(dt, dt_previous, dt_before)
    return c / (c_p - c)
