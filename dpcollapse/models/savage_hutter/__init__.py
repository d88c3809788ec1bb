"""Depth-averaged Savage–Hutter / Saint-Venant model of a granular layer on a plane slope.

Pure NumPy, one space dimension (x along the slope, thickness h measured normal to it)::

    ∂t h + ∂x(h ū) = 0
    ∂t(h ū) + ∂x(α h ū² + K g cosθ h²/2) = g h (sinθ − μ_eff sign(ū) cosθ)

with μ_eff the basal friction (Coulomb or μ(Ī), ``friction``) plus the optional side-wall term
μ_w h/w, and K = 1 (hydrostatic) or Savage & Hutter's earth-pressure coefficient
(``earth_pressure``). ``scheme`` holds the finite-volume step (HLL fluxes, friction that locks interfaces at
rest, implicit Coulomb stopping), ``solver`` the time loop and outputs, ``exact`` the analytic
solutions used for verification. The convergence study is a client in the checkout, not part
of the package (``python -m studies.savage_hutter``). See docs/savage_hutter.md.
"""

from dpcollapse.models.savage_hutter.earth_pressure import EarthPressure
from dpcollapse.models.savage_hutter.friction import CoulombFriction, MuIFriction, SideWallFriction
from dpcollapse.models.savage_hutter.solver import Grid, Result, SavageHutter, simulate

__all__ = [
           "CoulombFriction",
           "EarthPressure",
           "Grid",
           "MuIFriction",
           "Result",
           "SavageHutter",
           "SideWallFriction",
           "simulate",
]
