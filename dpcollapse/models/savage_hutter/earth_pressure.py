"""Earth-pressure coefficient K of Savage & Hutter (1989): the longitudinal stress of the layer.

Savage & Hutter (J. Fluid Mech. 199, 177–215, 1989) scale the depth-averaged longitudinal normal
stress by K times the hydrostatic (normal) one, so the momentum flux carries K g cosθ h²/2 and the
waves travel at ū ± √(K g cosθ h). From the Mohr–Coulomb yield of the material (internal
friction angle φ) with the basal shear at the bed friction angle δ ≤ φ::

    K_act/pass = 2 sec²φ (1 ∓ √(1 − cos²φ sec²δ)) − 1

active (the minus sign, K_act ≤ K_pass) where the layer stretches, ∂ū/∂x > 0, passive where it
is compressed, ∂ū/∂x < 0. δ > φ makes the root imaginary (the bed cannot be rougher than the
material shears): refused. At δ = φ both equal 2 sec²φ − 1 = 1 + 2 tan²φ (> 1); at δ = 0 they
are Rankine's (1 ∓ sin φ)/(1 ± sin φ).

Rule for ∂ū/∂x = 0 (in particular every cell at rest): Savage & Hutter's switch names only the
two strict signs, and the stress of a mass at rest is statically indeterminate between the two
states. We take the active value there (K = K_act for ∂ū/∂x ≥ 0): a mass released from rest
starts to move by stretching, so its first step and the following ones use the same K, and a
deposit at rest is held by the friction test with K_act (``scheme``, the locking test).

Cell rate of stretch: D_i = ū_{i+1} − ū_{i−1} over the wet neighbours; a dry neighbour (h ≤
h_dry) is replaced by the cell itself (one-sided difference), so the front cell of a spreading
layer, next to a still dry cell, is active as the rest of the layer. Ghost cells (``scheme``)
take their neighbour's K (a wall mirrors ū, so a layer moving away from the wall stretches).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["EarthPressure", "savage_hutter_coefficients"]


def savage_hutter_coefficients(phi_deg: float, delta_deg: float) -> tuple[float, float]:
    """(K_act, K_pass) = 2 sec²φ (1 ∓ √(1 − cos²φ sec²δ)) − 1 for 0 ≤ δ ≤ φ < 90° (degrees).

    ValueError when δ > φ (imaginary root) or the angles are out of range."""
    if not (0.0 < phi_deg < 90.0 and 0.0 <= delta_deg < 90.0):
        raise ValueError(f"need 0 < phi < 90 and 0 <= delta < 90 degrees, got phi = {phi_deg}, "
                         f"delta = {delta_deg}")
    if delta_deg > phi_deg:
        raise ValueError(f"bed friction angle delta = {delta_deg} deg exceeds the internal "
                         f"friction angle phi = {phi_deg} deg: K_act/pass is imaginary")
    phi, delta = math.radians(phi_deg), math.radians(delta_deg)
    sec2_phi = 1.0 / math.cos(phi) ** 2
    root = math.sqrt(max(0.0, 1.0 - math.cos(phi) ** 2 / math.cos(delta) ** 2))
    return 2.0 * sec2_phi * (1.0 - root) - 1.0, 2.0 * sec2_phi * (1.0 + root) - 1.0


@dataclass(frozen=True)
class EarthPressure:
    """K = k_active where the layer stretches or is at rest (∂ū/∂x ≥ 0), k_passive where it is
    compressed (module docstring). ``savage_hutter(φ, δ)`` gives Savage & Hutter's pair."""

    k_active: float
    k_passive: float

    def __post_init__(self):
        if not (0.0 < self.k_active <= self.k_passive and math.isfinite(self.k_passive)):
            raise ValueError(f"need 0 < k_active <= k_passive, got {self.k_active}, "
                             f"{self.k_passive}")

    @classmethod
    def savage_hutter(cls, phi_deg: float, delta_deg: float) -> EarthPressure:
        """Savage & Hutter's K_act/pass of internal friction φ and bed friction δ [deg]."""
        return cls(*savage_hutter_coefficients(phi_deg, delta_deg))

    def cell_coefficients(self, u_ext: np.ndarray, wet_ext: np.ndarray) -> np.ndarray:
        """K of every cell of a ghost-extended velocity array (ghosts copy their neighbour):
        K_act where D_i = ū_right − ū_left ≥ 0, K_pass where D_i < 0, with a dry neighbour
        replaced by the cell itself."""
        mid = u_ext[1:-1]
        right = np.where(wet_ext[2:], u_ext[2:], mid)
        left = np.where(wet_ext[:-2], u_ext[:-2], mid)
        k = np.empty(u_ext.size)
        k[1:-1] = np.where(right - left >= 0.0, self.k_active, self.k_passive)
        k[0], k[-1] = k[1], k[-2]
        return k
