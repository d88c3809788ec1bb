"""Basal and side-wall friction of the depth-averaged model, and their implicit (stopping) update.

The momentum equation per unit width (SI: h [m], ū [m/s], g [m/s²]) carries the friction term

    − g cosθ h μ_eff sign(ū),        μ_eff = μ_b(h, |ū|) + μ_w h / w

* Coulomb: μ_b constant (``CoulombFriction``).
* μ(I) (Jop, Forterre & Pouliquen 2006, seeds 003/004) with the depth-averaged inertial number of
  a Bagnold profile (``MuIFriction``)::

      μ(Ī) = μ_s + (μ_2 − μ_s) / (I0/Ī + 1),        Ī = (5/2) d |ū| / (h √(g h))

* Side walls of a channel of width w (``SideWallFriction``): the 2D model's width-averaged body
  force −(2/w) μ_w p u/|u| with the hydrostatic pressure p = ρ g cosθ (h − z), integrated over the
  depth 0 ≤ z ≤ h (u has the sign of ū across the layer)::

      ∫_0^h (2/w) μ_w ρ g cosθ (h − z) dz = (2/w) μ_w ρ g cosθ h²/2 = ρ g cosθ h (μ_w h / w)

  i.e. per unit mass an extra friction coefficient μ_w h/w added to μ_b.

At rest the friction is set-valued: any force of magnitude ≤ μ_static g cosθ h (μ_static = μ_b at
Ī = 0 plus μ_w h/w) is held. ``implicit_speed`` gives the speed after a friction step of length
Δt taken implicitly in the speed (Mangeney-Castelnau et al. 2003; Bouchut's stopping criterion)::

      |ū^{n+1}| = max(0, v)   with   v + Δt g cosθ μ_eff(h, v) = |ū*|

which stops the mass exactly (|ū^{n+1}| = 0) when |ū*| ≤ Δt g cosθ μ_static, and never reverses
the flow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CoulombFriction", "MuIFriction", "SideWallFriction", "depth_averaged_inertial_number"]


def depth_averaged_inertial_number(h, speed, grain_diameter: float, g: float):
    """Ī = (5/2) d |ū| / (h √(g h))  [-]: the inertial number of a Bagnold profile of mean |ū|.

    h [m] > 0, speed |ū| [m/s], grain_diameter d [m], g [m/s²]."""
    h = np.asarray(h, dtype=float)
    return 2.5 * grain_diameter * np.abs(speed) / (h * np.sqrt(g * h))


@dataclass(frozen=True)
class CoulombFriction:
    """Constant basal friction coefficient μ_b = tan δ (δ the bed friction angle)."""

    mu: float

    def __post_init__(self):
        if not (self.mu >= 0 and math.isfinite(self.mu)):
            raise ValueError(f"Coulomb friction coefficient must be >= 0, got {self.mu}")

    def describe(self) -> str:
        return f"Coulomb mu_b = {self.mu:.4f}"

    def static(self, h):
        """μ_b at rest (Ī = 0) [-], broadcast to h's shape."""
        return np.full(np.shape(h), self.mu)

    def coefficient(self, h, speed):
        """μ_b [-] (independent of h and |ū|)."""
        return np.full(np.broadcast(np.asarray(h), np.asarray(speed)).shape, self.mu)

    def implicit_speed(self, speed_pred, h, impulse, extra):
        """|ū^{n+1}| = max(|ū*| − A (μ_b + m), 0), A = Δt g cosθ [m/s], m = side-wall μ_w h/w."""
        return np.maximum(speed_pred - impulse * (self.mu + extra), 0.0)


@dataclass(frozen=True)
class MuIFriction:
    """μ(Ī) = μ_s + (μ_2 − μ_s)/(I0/Ī + 1), Ī = (5/2) d |ū|/(h √(g h)).

    mu_s, mu_2: static and limiting coefficients (μ_2 ≥ μ_s ≥ 0); i0: I0 > 0; grain_diameter: d
    [m] > 0; g [m/s²] the gravity used in Ī. Seed 004's column fit: μ_s = 0.32, μ_2 − μ_s = 0.28,
    I0 = 0.4.
    """

    mu_s: float
    mu_2: float
    i0: float
    grain_diameter: float
    g: float = 9.81

    def __post_init__(self):
        if not (0 <= self.mu_s <= self.mu_2 and math.isfinite(self.mu_2)):
            raise ValueError(f"need 0 <= mu_s <= mu_2, got {self.mu_s}, {self.mu_2}")
        if not (self.i0 > 0 and self.grain_diameter > 0 and self.g > 0):
            raise ValueError("i0, grain_diameter and g must be > 0")

    def describe(self) -> str:
        return f"mu(I): mu_s = {self.mu_s:.4f}, mu_2 = {self.mu_2:.4f}"

    def static(self, h):
        """μ(0) = μ_s [-], broadcast to h's shape."""
        return np.full(np.shape(h), self.mu_s)

    def coefficient(self, h, speed):
        """μ(Ī(h, |ū|)) [-]; h [m] > 0."""
        inertial = depth_averaged_inertial_number(h, speed, self.grain_diameter, self.g)
        return self.mu_s + (self.mu_2 - self.mu_s) * inertial / (self.i0 + inertial)

    def implicit_speed(self, speed_pred, h, impulse, extra):
        """Solve v + A (μ(Ī(h, v)) + m) = V for v ≥ 0 (0 when V ≤ A (μ_s + m)).

        With Ī = k v, k = (5/2) d/(h √(g h)), B = A (μ_s + m) − V < 0 and Δμ = μ_2 − μ_s,
        multiplying by (I0 + k v) gives k v² + (I0 + k (B + A Δμ)) v + I0 B = 0, whose roots have
        the product I0 B / k < 0: exactly one is positive (v + A μ(kv) is increasing in v). It is
        evaluated as v = −2 I0 B / (b + √(b² − 4 k I0 B)) (no cancellation)."""
        k = 2.5 * self.grain_diameter / (h * np.sqrt(self.g * h))
        slack = impulse * (self.mu_s + extra) - speed_pred  # B
        b = self.i0 + k * (slack + impulse * (self.mu_2 - self.mu_s))
        root = -2.0 * self.i0 * slack / (b + np.sqrt(b * b - 4.0 * k * self.i0 * slack))
        return np.where(slack < 0.0, root, 0.0)


@dataclass(frozen=True)
class SideWallFriction:
    """Side walls of a channel of width w [m] with friction coefficient μ_w = tan δ_w.

    Depth-averaged contribution to the friction coefficient: μ_w h / w (module docstring)."""

    mu_w: float
    width: float

    def __post_init__(self):
        if not (self.mu_w >= 0 and self.width > 0):
            raise ValueError(f"need mu_w >= 0 and width > 0, got {self.mu_w}, {self.width}")

    def coefficient(self, h):
        """μ_w h / w [-]."""
        return self.mu_w * np.asarray(h, dtype=float) / self.width

    def force_per_width(self, h, rho: float, g: float, cos_theta: float):
        """Depth-integrated width-averaged side-wall force per unit bed area [N/m²]:
        ∫_0^h (2/w) μ_w ρ g cosθ (h − z) dz = μ_w ρ g cosθ h² / w (ρ [kg/m³])."""
        h = np.asarray(h, dtype=float)
        return self.mu_w * rho * g * cos_theta * h * h / self.width
