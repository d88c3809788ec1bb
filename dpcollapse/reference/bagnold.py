r"""Bagnold profile: steady uniform μ(I) flow of a layer down a slope (seeds 003/004).

A layer of thickness h on a slope θ (y normal to the bed: 0 at the bed, h at the free
surface), no slip at the bed, stress free surface. Momentum balance::

    p = ρ g cosθ (h − y),   τ = ρ g sinθ (h − y)   ⇒   τ/p = tanθ = μ(I)

(ρ the bulk density), so I is uniform, I_θ = μ⁻¹(tanθ) = I0 (tanθ − μ_s)/(μ_2 − tanθ), which
needs μ_s < tanθ < μ_2 and cohesion κ0 = 0 (with κ0 > 0, τ/p is not uniform; ValueError).
With I = d γ̇/√(p/ρ_s) (ρ_s the grain density)::

    γ̇(y) = (I_θ/d) √(p/ρ_s) = (I_θ/d) √(g cosθ ρ/ρ_s) √(h − y),
    u(y) = ∫₀^y γ̇ = (2/3)(I_θ/d) √(g cosθ ρ/ρ_s) [h^{3/2} − (h − y)^{3/2}],

which for ρ = ρ_s is the reference README's u(y) = (2/3)(I_θ/d)√(g cosθ)[h^{3/2} − (h−y)^{3/2}].
Surface velocity u_s = (2/3)(I_θ/d) √(g cosθ ρ/ρ_s) h^{3/2}; depth average ū = (3/5) u_s.

Basilisk ``bagnold_periodic`` (θ = 0.43, d = 0.04, μ_s = 0.38, Δμ = 0.26, I0 = 0.3,
g = h = 1, ρ = ρ_s): I_θ = 0.130039, u_s = 2.066310 — the value that run reports (2.06631).
(3.0995 = (3/2) u_s is the same expression without the 2/3.)
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "bagnold_inertial_number",
    "bagnold_velocity",
    "bagnold_surface_velocity",
    "bagnold_mean_velocity",
    "bagnold_shear_rate",
]


def bagnold_inertial_number(law, theta: float) -> float:
    """I_θ = I0 (tanθ − μ_s)/(μ_2 − tanθ); ValueError unless μ_s < tanθ < μ_2 and κ0 = 0."""
    if law.cohesion > 0:
        raise ValueError(f"Bagnold profile needs cohesion = 0, got {law.cohesion}")
    t = math.tan(theta)
    if not (0 < theta < math.pi / 2) or not (law.mu_s < t < law.mu_2):
        raise ValueError(
            f"Bagnold flow needs mu_s < tan(theta) < mu_2; got tan({theta}) = {t:.6g}, "
            f"mu_s = {law.mu_s}, mu_2 = {law.mu_2}"
        )
    return law.I0 * (t - law.mu_s) / (law.mu_2 - t)


def _prefactor(law, theta, density, gravity):
    """(I_θ/d) √(g cosθ ρ/ρ_s)  [1/(s √m)]."""
    if not (density > 0 and gravity > 0):
        raise ValueError(f"density and gravity must be > 0, got {density}, {gravity}")
    I = bagnold_inertial_number(law, theta)
    return I / law.grain_diameter * math.sqrt(gravity * math.cos(theta) * density / law.grain_density)


def _check_h(h):
    if not (h > 0 and math.isfinite(h)):
        raise ValueError(f"thickness h must be > 0, got {h}")


def bagnold_shear_rate(law, theta, h, y, density, gravity=9.81):
    """γ̇(y) = (I_θ/d) √(g cosθ ρ/ρ_s) √(h − y) for 0 ≤ y ≤ h."""
    _check_h(h)
    y = np.asarray(y, dtype=float)
    if np.any(y < 0) or np.any(y > h):
        raise ValueError("y must lie in [0, h]")
    g = _prefactor(law, theta, density, gravity) * np.sqrt(h - y)
    return float(g) if g.ndim == 0 else g


def bagnold_velocity(law, theta, h, y, density, gravity=9.81):
    """u(y) = (2/3)(I_θ/d) √(g cosθ ρ/ρ_s) [h^{3/2} − (h − y)^{3/2}] for 0 ≤ y ≤ h (y from the bed)."""
    _check_h(h)
    y = np.asarray(y, dtype=float)
    if np.any(y < 0) or np.any(y > h):
        raise ValueError("y must lie in [0, h]")
    u = (2.0 / 3.0) * _prefactor(law, theta, density, gravity) * (h**1.5 - (h - y) ** 1.5)
    return float(u) if u.ndim == 0 else u


def bagnold_surface_velocity(law, theta, h, density, gravity=9.81):
    """u(h) = (2/3)(I_θ/d) √(g cosθ ρ/ρ_s) h^{3/2}."""
    return bagnold_velocity(law, theta, h, h, density, gravity)


def bagnold_mean_velocity(law, theta, h, density, gravity=9.81):
    """ū = (1/h)∫₀^h u dy = (3/5) u(h)."""
    return 0.6 * bagnold_surface_velocity(law, theta, h, density, gravity)
