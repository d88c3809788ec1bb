"""Regularized Drucker–Prager viscoplastic law (seeds 000/001).

Deviatoric stress, with the Frobenius norm |D| = √(D:D) (the project's convention)::

    σ' = 2η D(u) + κ(p) D(u) / √(|D(u)|² + ε²),      κ(p) = √2 μ_s [p]_+

In simple shear u = (γ̇ y, 0): D:D = γ̇²/2, so τ = σ'_xy = η γ̇ + μ_s [p]_+ γ̇ / √(γ̇² + 2ε²)
→ μ_s p as ε → 0: the Coulomb criterion τ = μ_s p.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from dpcollapse.rheology.coordinates import PLANAR, Planar
from dpcollapse.rheology.kinematics import frobenius_norm_sq, positive_part, regularized_secant, strain_rate

__all__ = ["DruckerPrager", "frobenius_norm_sq", "positive_part", "strain_rate"]


@dataclass(frozen=True)
class DruckerPrager:
    """σ' = 2η D + κ(p) D/√(|D|²+ε²), κ(p) = √2 (κ0 + μ_s [p]_+), κ0 the cohesion [Pa].

    viscosity: η [Pa s] ≥ 0; friction_coefficient: μ_s = tan(internal friction angle) ≥ 0
    (μ_s = κ0 = 0: a Newtonian fluid, σ' = 2η D).
    """

    viscosity: float
    friction_coefficient: float
    cohesion: float = 0.0
    #: planar or axisymmetric (``rheology.coordinates``): D(u) and |D| with the hoop rate
    coordinates: Planar = PLANAR

    #: no cap: S = 2η + κ/|D|_ε is bounded below by 2η, not above
    viscosity_cap: ClassVar[None] = None
    #: η does not depend on (|D|, p)
    rate_dependent: ClassVar[bool] = False
    #: its ``material.rheology``
    name: ClassVar[str] = "drucker_prager"
    #: no grain size enters the law [m]
    grain_scale: ClassVar[float] = 0.0

    @classmethod
    def from_material(cls, m) -> DruckerPrager:
        """The law of a config's ``material`` section (η, μ_s, cohesion)."""
        return cls(m.viscosity, m.mu_s, m.cohesion)

    def __post_init__(self):
        if not (self.cohesion >= 0 and math.isfinite(self.cohesion)):
            raise ValueError(f"cohesion must be >= 0, got {self.cohesion}")
        if not (self.viscosity >= 0 and math.isfinite(self.viscosity)):
            raise ValueError(f"viscosity must be >= 0, got {self.viscosity}")
        if not (self.friction_coefficient >= 0 and math.isfinite(self.friction_coefficient)):
            raise ValueError(f"friction_coefficient must be >= 0, got {self.friction_coefficient}")

    def yield_stress(self, p):
        """κ(p) = √2 (κ0 + μ_s [p]_+)  [Pa]: in simple shear the yield stress κ0 + μ_s p."""
        return math.sqrt(2.0) * (self.cohesion + self.friction_coefficient * positive_part(p))

    def rate_viscosity(self, u, p, epsilon):
        """η [Pa s]: the rate-dependent part σ' − κ D/|D| = 2η D, constant here."""
        return self.viscosity

    def capped_rate_viscosity(self, u, p, epsilon):
        """η [Pa s] (no cap)."""
        return self.viscosity

    def secant_viscosity(self, u, p, epsilon):
        """The coefficient of D(v) in the Picard linearization: 2η + κ(p)/√(|D(u)|²+ε²)."""
        return regularized_secant(self.yield_stress(p), self.viscosity, u, epsilon,
                                  coordinates=self.coordinates)

    def deviatoric_stress(self, u, p, epsilon):
        """σ'(u, p) of the regularized law [Pa]."""
        return self.secant_viscosity(u, p, epsilon) * self.coordinates.strain_rate(u)

    def diagnostic_fields(self, u, p, epsilon) -> dict:
        """None beyond the common ones."""
        return {}

    def describe(self) -> str:
        """Nothing beyond μ_s, which every summary prints (empty)."""
        return ""

    def well_posed_window(self) -> tuple[float, float] | None:
        """Not a μ(I) law: no inertial-number window (None)."""
        return None
