"""The ALE mesh velocity w (seed 000): an elliptic extension of the boundary motion.

    −div D(w) = 0 in Ω,   (w − u)·n = 0 on Γ,   (D(w)n)_T = 0 on Γ.

On the bed (y = 0) and the left wall (x = 0) of a collapse, u·n = 0 exactly, so w·n = 0
is imposed strongly there (nodes slide along them and never leave them); on the free
surface the kinematic condition is imposed by a penalty scaled by the cell size h::

    ∫ D(w):D(z) dx + ∫_{Γ_f} (ξ̂/h) ((w − u)·n)(z·n) ds = 0.
"""

from __future__ import annotations

import ufl
from ufl.domain import extract_unique_domain

from dpcollapse.rheology.kinematics import strain_rate


def mesh_velocity_forms(w, z, u, penalty, ds_surface):
    """Bilinear and linear forms (a, L) of the penalized mesh-velocity problem."""
    mesh = extract_unique_domain(w)
    n = ufl.FacetNormal(mesh)
    h = ufl.CellDiameter(mesh)
    a = ufl.inner(strain_rate(w), strain_rate(z)) * ufl.dx
    a += penalty / h * ufl.dot(w, n) * ufl.dot(z, n) * ds_surface
    L = penalty / h * ufl.dot(u, n) * ufl.dot(z, n) * ds_surface
    return a, L
