"""The local surface tension of seed 000 as a boundary term of the momentum equation.

With the traction σ·N = −γ N on the free surface Γ_f (γ from
:func:`dpcollapse.geometry.curvature.local_surface_tension`, positive on a convex bulge),
integrating the momentum balance by parts against a test velocity v gives on the right-hand
side

    ∫_{Γ_f} (σ·N)·v ds = −∫_{Γ_f} γ v·N ds.

γ is given (computed from the surface geometry of the last accepted step), so the term is
explicit and enters only the right-hand side.
"""

from __future__ import annotations

import ufl


def surface_tension(gamma, v, normal, ds_surface):
    """Right-hand-side term −∫_{Γ_f} γ v·N ds of the local surface tension [W]."""
    return -gamma * ufl.dot(v, normal) * ds_surface
