"""Analytic solutions of the Savage–Hutter equations used for verification (α = 1, SI units).

Mangeney, Heinrich & Roche (2000), dam break on a slope θ with Coulomb friction tan δ, reservoir
h0 for x < 0 at t = 0 (x along the slope)::

    c0 = √(g h0 cosθ),   m = g sinθ − g cosθ tanδ   (m ≥ 0: the reservoir slides)
    x ≤ m t²/2 − c0 t:                 h = h0,                             ū = m t
    m t²/2 − c0 t < x ≤ m t²/2 + 2c0 t: h = (2c0 − x/t + m t/2)² / (9 g cosθ),
                                       ū = (2/3)(c0 + x/t + m t)
    x > m t²/2 + 2c0 t:                h = 0

Kerswell (2005), flat bed, friction μ, reservoir h0 released at x0: the front moves as
x_f − x0 = 2√(g h0) t − μ g t²/2 and stops at t_stop = 2√(h0/g)/μ, at x_stop − x0 = 2h0/μ.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["kerswell_front", "kerswell_runout", "kerswell_stop_time", "mangeney_dam_break"]


def mangeney_dam_break(x, t: float, h0: float, theta_deg: float, delta_deg: float,
                       g: float = 9.81):
    """(h, ū) of Mangeney et al. (2000) at positions x [m] and time t > 0 [s] (dam at x = 0)."""
    x = np.asarray(x, dtype=float)
    theta, delta = math.radians(theta_deg), math.radians(delta_deg)
    g_cos = g * math.cos(theta)
    c0 = math.sqrt(g_cos * h0)
    m = g * math.sin(theta) - g_cos * math.tan(delta)
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
