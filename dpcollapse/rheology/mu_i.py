r"""Regularized μ(I) rheology (Jop, Forterre & Pouliquen 2006; seeds 002/003/004), with cohesion
and an optional viscosity cap (Gerris/Basilisk).

Norm convention (the project's): |D| = √(D:D) (Frobenius). In simple shear u = (γ̇ y, 0),
D:D = γ̇²/2, so γ̇ = √2 |D|. Regularized rate: |D|_ε = √(|D|² + ε²), γ̇_ε = √2 |D|_ε.

    I = d γ̇ / √(p/ρ_s) = d √2 |D| / √(p/ρ_s),        μ(I) = μ_s + (μ_2 − μ_s) I / (I0 + I)

(seed 002 writes I = 2‖D‖d/√(p/ρ_s) with ‖D‖ = √(D:D/2): the same number.)

Deviatoric stress σ' = S(u, p) D(u) with the secant viscosity (coefficient of D(v) in the
Picard linearization)::

    S = min( √2 (κ0 + μ_s [p]_+) / |D|_ε  +  2 (μ_2 − μ_s) [p]_+ / (√2 |D|_ε + I0 √([p]_+/ρ_s)/d),
             2 η_max )

Derivation (simple shear, σ'_xy = S D_xy = S γ̇/2, target τ = κ0 + μ(I) p):
  1. μ(I) p = μ_s p + (μ_2 − μ_s) p I/(I0 + I) = μ_s p + (μ_2 − μ_s) p γ̇ / (γ̇ + I0 √(p/ρ_s)/d).
  2. Plastic part: S_pl γ̇/2 = κ0 + μ_s p ⇔ S_pl = 2(κ0 + μ_s p)/γ̇ = √2 (κ0 + μ_s p)/|D|.
  3. Rate part: S_v γ̇/2 = (μ_2 − μ_s) p γ̇/(γ̇ + I0√(p/ρ_s)/d) ⇔ S_v = 2 η_μI,
     η_μI = (μ_2 − μ_s) p / (√2|D| + I0 √(p/ρ_s)/d); then |D| → |D|_ε.
So τ = (κ0 + μ_s p) γ̇/√(γ̇² + 2ε²) + (μ_2 − μ_s) p γ̇ / (√(γ̇² + 2ε²) + I0 √(p/ρ_s)/d)
→ κ0 + μ(I) p as ε → 0.  (Seed 002's viscous term (μ_2 − μ_s) p D/(‖D‖ + I0√p/(d√ρ)) puts
‖D‖ = γ̇/2 where I/(I0 + I) needs γ̇: it corresponds to I0 doubled; we do not copy it.)

Cap: Gerris/Basilisk use σ' = 2η D with η = min(η_max, max(μ(I) p/(√2 |D|), 0)) (|D| Frobenius,
their D_2). Our S is their 2η, so the cap is S ≤ 2 η_max; when it is active, σ'_xy = η_max γ̇
(the same meaning of "viscosity" as η in DruckerPrager, whose S = 2η + ...). The cap applies to
the total (plastic + rate) secant viscosity.

Negative pressure: [p]_+ is formed before I, κ and η_μI, so tension gives zero plastic and rate
stress. Inside square roots p is replaced by [p]_+ + PRESSURE_FLOOR (1e-10 Pa) so that I is
finite at p ≤ 0 and the UFL expression stays differentiable in p; the relative change of √p is
≤ 5e-11 for p ≥ 1 Pa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import ufl

from dpcollapse.rheology.coordinates import PLANAR, Planar
from dpcollapse.rheology.kinematics import frobenius_norm_sq, positive_part, regularized_secant

PRESSURE_FLOOR = 1e-10
"""Pressure [Pa] added to [p]_+ under square roots (I and the rate-dependent viscosity)."""

SQRT2 = math.sqrt(2.0)

__all__ = ["MuI", "PRESSURE_FLOOR"]


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


@dataclass(frozen=True)
class MuI:
    r"""μ(I) law: σ' = S D, S = min(√2(κ0 + μ_s[p]_+)/|D|_ε + 2η_μI, 2η_max).

    η_μI = (μ_2 − μ_s)[p]_+ / (√2|D|_ε + I0 √([p]_+/ρ_s)/d); |D| = √(D:D), |D|_ε = √(|D|²+ε²).
    In simple shear τ → κ0 + μ(I) p with I = d γ̇/√(p/ρ_s) (see the module docstring).

    mu_s: static friction coefficient μ_s > 0; mu_2: limiting friction μ_2 > μ_s;
    I0: inertial-number scale > 0; grain_diameter d [m] > 0; grain_density ρ_s [kg/m³] > 0;
    cohesion κ0 [Pa] ≥ 0 (yield stress in simple shear at p = 0);
    viscosity_cap η_max [Pa s] > 0 or None (σ'_xy ≤ η_max γ̇ when given).
    """

    mu_s: float
    mu_2: float
    I0: float
    grain_diameter: float
    grain_density: float
    cohesion: float = 0.0
    viscosity_cap: float | None = None
    #: planar or axisymmetric (``rheology.coordinates``): D(u), |D| and I with the hoop rate
    coordinates: Planar = PLANAR

    pressure_floor: ClassVar[float] = PRESSURE_FLOOR
    #: η_μI depends on |D| and p
    rate_dependent: ClassVar[bool] = True
    #: its ``material.rheology``
    name: ClassVar[str] = "mu_i"

    @classmethod
    def from_material(cls, m) -> MuI:
        """The law of a config's ``material`` section."""
        return cls(mu_s=m.mu_s, mu_2=m.mu_2, I0=m.inertial_number_I0, grain_diameter=m.grain_diameter,
                   grain_density=m.grain_density, cohesion=m.cohesion, viscosity_cap=m.viscosity_cap)

    @property
    def grain_scale(self) -> float:
        """The grain size d [m] (the thinnest film the flow can carry is a few d)."""
        return self.grain_diameter

    def __post_init__(self):
        if not (_finite(self.mu_s) and self.mu_s > 0):
            raise ValueError(f"mu_s must be > 0, got {self.mu_s}")
        if not (_finite(self.mu_2) and self.mu_2 > self.mu_s):
            raise ValueError(f"mu_2 must be > mu_s = {self.mu_s}, got {self.mu_2}")
        if not (_finite(self.I0) and self.I0 > 0):
            raise ValueError(f"I0 must be > 0, got {self.I0}")
        if not (_finite(self.grain_diameter) and self.grain_diameter > 0):
            raise ValueError(f"grain_diameter must be > 0 [m], got {self.grain_diameter}")
        if not (_finite(self.grain_density) and self.grain_density > 0):
            raise ValueError(f"grain_density must be > 0 [kg/m^3], got {self.grain_density}")
        if not (_finite(self.cohesion) and self.cohesion >= 0):
            raise ValueError(f"cohesion must be >= 0 [Pa], got {self.cohesion}")
        if self.viscosity_cap is not None and not (_finite(self.viscosity_cap) and self.viscosity_cap > 0):
            raise ValueError(f"viscosity_cap must be > 0 [Pa s] or None, got {self.viscosity_cap}")

    # ------------------------------------------------------------------ numpy
    @property
    def delta_mu(self) -> float:
        """μ_2 − μ_s."""
        return self.mu_2 - self.mu_s

    def friction(self, I):
        """μ(I) = μ_s + (μ_2 − μ_s)/(I0/I + 1) = μ_s + (μ_2 − μ_s) I/(I0 + I); μ(0) = μ_s.

        Accepts scalars or arrays (I ≥ 0); returns a float for a scalar."""
        I = np.asarray(I, dtype=float)
        if np.any(I < 0):
            raise ValueError("inertial number must be >= 0")
        mu = self.mu_s + self.delta_mu * I / (self.I0 + I)
        return float(mu) if mu.ndim == 0 else mu

    def friction_derivative(self, I):
        """μ'(I) = (μ_2 − μ_s) I0/(I0 + I)²."""
        I = np.asarray(I, dtype=float)
        if np.any(I < 0):
            raise ValueError("inertial number must be >= 0")
        dmu = self.delta_mu * self.I0 / (self.I0 + I) ** 2
        return float(dmu) if dmu.ndim == 0 else dmu

    def inertial_number_np(self, gamma_dot, p):
        """I = d γ̇ / √(([p]_+ + PRESSURE_FLOOR)/ρ_s), γ̇ = √2|D| the engineering shear rate [1/s].

        Same floor as the UFL version, so p ≤ 0 gives a large finite I (not inf/NaN)."""
        gamma_dot = np.abs(np.asarray(gamma_dot, dtype=float))
        p = np.asarray(p, dtype=float)
        I = (
            self.grain_diameter
            * gamma_dot
            / np.sqrt((np.maximum(p, 0.0) + self.pressure_floor) / self.grain_density)
        )
        return float(I) if I.ndim == 0 else I

    # ------------------------------------------------------------------ UFL
    def _sqrt_p_over_rho(self, p):
        """√(([p]_+ + PRESSURE_FLOOR)/ρ_s) [m/s] as UFL (finite and differentiable for any p)."""
        return ufl.sqrt((positive_part(p) + self.pressure_floor) / self.grain_density)

    def yield_stress(self, p):
        """κ(p) = √2 (κ0 + μ_s [p]_+) [Pa] (Frobenius norm: τ = κ0 + μ_s p in simple shear)."""
        return SQRT2 * (self.cohesion + self.mu_s * positive_part(p))

    def inertial_number(self, u, p, epsilon):
        """I = d √2 √(|D|²+ε²) / √(([p]_+ + PRESSURE_FLOOR)/ρ_s) as UFL (finite for p ≤ 0)."""
        D = self.coordinates.strain_rate(u)
        rate = SQRT2 * ufl.sqrt(frobenius_norm_sq(D) + epsilon**2)
        return self.grain_diameter * rate / self._sqrt_p_over_rho(p)

    def rate_viscosity(self, u, p, epsilon):
        """η_μI = (μ_2 − μ_s)[p]_+ / (√2|D|_ε + I0 √([p]_+/ρ_s)/d)  [Pa s] (uncapped)."""
        D = self.coordinates.strain_rate(u)
        rate = SQRT2 * ufl.sqrt(frobenius_norm_sq(D) + epsilon**2)
        return (
            self.delta_mu
            * positive_part(p)
            / (rate + self.I0 * self._sqrt_p_over_rho(p) / self.grain_diameter)
        )

    def capped_rate_viscosity(self, u, p, epsilon):
        """min(η_μI, η_max) [Pa s] (η_μI when viscosity_cap is None)."""
        eta = self.rate_viscosity(u, p, epsilon)
        if self.viscosity_cap is not None:
            eta = ufl.min_value(eta, self.viscosity_cap)
        return eta

    def secant_viscosity(self, u, p, epsilon):
        """Coefficient of D(v) in the Picard linearization:
        S = min(κ(p)/√(|D|²+ε²) + 2 η_μI, 2 η_max) (no min when viscosity_cap is None)."""
        return regularized_secant(self.yield_stress(p), self.rate_viscosity(u, p, epsilon), u,
                                  epsilon, self.viscosity_cap, self.coordinates)

    def deviatoric_stress(self, u, p, epsilon):
        """σ'(u, p) = S(u, p) D(u) [Pa]."""
        return self.secant_viscosity(u, p, epsilon) * self.coordinates.strain_rate(u)

    def diagnostic_fields(self, u, p, epsilon) -> dict:
        """The inertial number I per cell."""
        return {"inertial_number": self.inertial_number(u, p, epsilon)}

    def describe(self) -> str:
        """One line for ``dpcollapse check``: the parameters beyond μ_s and the window of I
        where the law is well posed."""
        lo, hi = self.well_posed_window()
        window = f"{lo:.4g} < I < {hi:.4g}" if lo == lo else "empty (ill-posed for every I)"
        return (f"mu(I): mu_2 = {self.mu_2:.4f}, I0 = {self.I0:g}, d = {self.grain_diameter:g} m; "
                f"well-posed (Barker et al. 2015) for {window}")

    def well_posed_window(self) -> tuple[float, float]:
        """(I_min, I_max) of Barker et al. (2015) (``rheology.wellposedness``); (nan, nan)
        when the law is nowhere well posed."""
        from dpcollapse.rheology.wellposedness import well_posed_window

        return well_posed_window(self)
