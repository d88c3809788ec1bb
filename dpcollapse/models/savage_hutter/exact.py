"""Analytic solutions of the Savage–Hutter equations used for verification (α = 1, SI units).

Mangeney, Heinrich & Roche (2000), dam break on a slope θ with Coulomb friction tan δ, reservoir
h0 for x < 0 at t = 0 (x along the slope)::

    c0 = √(g h0 cosθ),   m = g sinθ − g cosθ tanδ   (m ≥ 0: the reservoir slides)
    x ≤ m t²/2 − c0 t:                 h = h0,                             ū = m t
    m t²/2 − c0 t < x ≤ m t²/2 + 2c0 t: h = (2c0 − x/t + m t/2)² / (9 g cosθ),
                                       ū = (2/3)(c0 + x/t + m t)
    x > m t²/2 + 2c0 t:                h = 0

With an earth-pressure coefficient K (uniform in the fan, where ∂ū/∂x = 2/(3t) > 0: K_act) the
same solution holds with g cosθ replaced by K g cosθ in the pressure: c0 = √(K g h0 cosθ),
h = (2c0 − x/t + m t/2)² / (9 K g cosθ) (``k`` argument).

Savage & Hutter (1989) parabolic cap (their similarity solution; α = 1, Coulomb friction, ū > 0
everywhere so that the friction is uniform), half-length L and peak H at t = 0, centre x_c::

    h = (H/s) (1 − ξ²),  ξ = (x − x_c)/(L s),   ū = u_c + (x − x_c) ṡ/s,
    ẍ_c = u̇_c = m,   s̈ = 2 K g cosθ H / (L² s²),   s(0) = 1, ṡ(0) = ṡ0

(substituting into ∂t ū + ū ∂x ū = g sinθ − μ g cosθ − K g cosθ ∂x h and mass conservation gives
exactly these ODEs). ∂ū/∂x = ṡ/s: a spreading cap (ṡ > 0) is active, a contracting one (ṡ < 0)
passive, with one K over the whole cap. It holds while ū > 0 on the whole cap:
u_c − L|ṡ| > 0 (spreading: the rear; contracting: the front).

Kerswell (2005), flat bed, friction μ, reservoir h0 released at x0: the front moves as
x_f − x0 = 2√(g h0) t − μ g t²/2 and stops at t_stop = 2√(h0/g)/μ, at x_stop − x0 = 2h0/μ.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["kerswell_front", "kerswell_runout", "kerswell_stop_time", "mangeney_dam_break",
           "parabolic_cap", "cap_stretch"]


def mangeney_dam_break(x, t: float, h0: float, theta_deg: float, delta_deg: float,
                       g: float = 9.81, k: float = 1.0):
    """(h, ū) of Mangeney et al. (2000) at positions x [m] and time t > 0 [s] (dam at x = 0);
    k: the earth-pressure coefficient of the fan (1: hydrostatic)."""
    x = np.asarray(x, dtype=float)
    theta, delta = math.radians(theta_deg), math.radians(delta_deg)
    g_cos = g * math.cos(theta)
    m = g * math.sin(theta) - g_cos * math.tan(delta)
    g_cos *= k                  # the pressure's K g cosθ (m keeps the plain g cosθ)
    c0 = math.sqrt(g_cos * h0)
    if m < 0:
        raise ValueError("the solution holds for a sliding reservoir: tan(theta) >= tan(delta)")
    if t <= 0:
        return np.where(x <= 0, h0, 0.0), np.zeros_like(x)
    rear = m * t * t / 2 - c0 * t
    tip = m * t * t / 2 + 2 * c0 * t
    fan_h = (2 * c0 - x / t + m * t / 2) ** 2 / (9 * g_cos)
    fan_u = (2.0 / 3.0) * (c0 + x / t + m * t)
    h = np.where(x <= rear, h0, np.where(x <= tip, fan_h, 0.0))
    u = np.where(x <= rear, m * t, np.where(x <= tip, fan_u, 0.0))
    return h, u


def kerswell_stop_time(h0: float, mu: float, g: float = 9.81) -> float:
    """t_stop = 2 √(h0/g) / μ [s]."""
    return 2.0 * math.sqrt(h0 / g) / mu


def kerswell_runout(h0: float, mu: float) -> float:
    """x_stop − x0 = 2 h0 / μ [m]."""
    return 2.0 * h0 / mu


def kerswell_front(t, h0: float, mu: float, g: float = 9.81):
    """x_f − x0 = 2√(g h0) t − μ g t²/2 for t ≤ t_stop, then 2h0/μ [m]."""
    t = np.minimum(np.asarray(t, dtype=float), kerswell_stop_time(h0, mu, g))
    return 2.0 * math.sqrt(g * h0) * t - 0.5 * mu * g * t * t


def cap_stretch(t: float, strength: float, rate0: float = 0.0, steps: int = 4000):
    """(s, ṡ) at time t of s̈ = strength / s², s(0) = 1, ṡ(0) = rate0 (classical RK4 with
    ``steps`` steps: error ~1e-13 for the tests' cases). strength = 2 K g cosθ H / L² [1/s²]."""
    if t < 0:
        raise ValueError("t must be >= 0")
    y = np.array([1.0, rate0])

    def f(v):
        return np.array([v[1], strength / (v[0] * v[0])])

    dt = t / steps
    for _ in range(steps if t > 0 else 0):
        k1 = f(y)
        k2 = f(y + 0.5 * dt * k1)
        k3 = f(y + 0.5 * dt * k2)
        k4 = f(y + dt * k3)
        y = y + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return float(y[0]), float(y[1])


def parabolic_cap(x, t: float, height: float, half_length: float, theta_deg: float,
                  delta_deg: float, k: float, centre0: float = 0.0, speed0: float = 0.0,
                  rate0: float = 0.0, g: float = 9.81):
    """(h, ū) of Savage & Hutter's parabolic cap (module docstring) at x [m], time t [s].

    height H, half_length L [m] at t = 0, centre0 x_c(0), speed0 u_c(0) [m/s], rate0 ṡ(0) [1/s],
    k the earth-pressure coefficient (K_act if the cap spreads, K_pass if it contracts). Valid
    while ū > 0 on the cap (ValueError otherwise)."""
    x = np.asarray(x, dtype=float)
    theta, delta = math.radians(theta_deg), math.radians(delta_deg)
    g_cos = g * math.cos(theta)
    m = g * math.sin(theta) - g_cos * math.tan(delta)
    s, rate = cap_stretch(t, 2.0 * k * g_cos * height / half_length ** 2, rate0)
    centre = centre0 + speed0 * t + 0.5 * m * t * t
    u_c = speed0 + m * t
    if u_c - half_length * abs(rate) <= 0.0:
        raise ValueError(f"the cap has a point at rest or moving upslope at t = {t:g} s: "
                         "the solution assumes u > 0 everywhere")
    xi = (x - centre) / (half_length * s)
    inside = np.abs(xi) < 1.0
    h = np.where(inside, height / s * (1.0 - xi * xi), 0.0)
    u = np.where(inside, u_c + (x - centre) * rate / s, 0.0)
    return h, u
