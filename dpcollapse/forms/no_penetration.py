"""No penetration u·n = 0 on a straight solid side at any angle, imposed weakly (Nitsche).

A side parallel to an axis gets u·n = 0 strongly, on one velocity component. A slanted side
(a hopper wall, a rotated bed) has no such component; Nitsche's method imposes it through
the normal traction that the integration by parts of the stress leaves on the boundary.
With σ(u, p) = S D(u) − p I (S the secant viscosity of the step's operator) and
σ_nn = n·σ n, the symmetric terms on the side Γ are::

    −∫_Γ σ_nn(u, p) (v·n) ds − ∫_Γ σ_nn(v, q) (u·n) ds + ∫_Γ γ S/h (u·n)(v·n) ds

(h the cell diameter, γ the dimensionless Nitsche parameter). They are consistent: the
exact solution, with u·n = 0, satisfies them, so a solution that the finite-element space
contains is reproduced to round-off (``tests/unit/test_no_penetration.py``: a rotated
half-Poiseuille channel). The tangential traction is left to the boundary's kind: zero
(slip) or Coulomb friction (``forms.friction``, which takes n from the facet). The
``penalty`` variant keeps only the last term: simpler, but inconsistent — its error falls
only as 1/γ (measured in the same test).
"""

from __future__ import annotations

import ufl

from dpcollapse.rheology.kinematics import strain_rate

#: γ of the Nitsche term: it must be large enough for coercivity (of order 10 for P2 on
#: shape-regular cells); the rotated channel is exact for every γ from 1 to 1e4 (it is
#: consistent), so 100 keeps a margin on stretched boundary cells at no cost in accuracy.
NITSCHE_PARAMETER = 100.0


def normal_stress(viscosity, u, p, n):
    """σ_nn = n·(S D(u) − p I) n [Pa]."""
    return viscosity * ufl.dot(n, ufl.dot(strain_rate(u), n)) - p


def nitsche_no_penetration(viscosity, u, p, v, q, n, ds, gamma=NITSCHE_PARAMETER):
    """−∫ σ_nn(u,p)(v·n) − ∫ σ_nn(v,q)(u·n) + ∫ γ S/h (u·n)(v·n) on the measure ``ds``."""
    h = ufl.CellDiameter(ds.ufl_domain())
    un, vn = ufl.dot(u, n), ufl.dot(v, n)
    return (-normal_stress(viscosity, u, p, n) * vn - normal_stress(viscosity, v, q, n) * un
            + gamma * viscosity / h * un * vn) * ds


def penalty_no_penetration(viscosity, u, v, n, ds, gamma=NITSCHE_PARAMETER):
    """∫ γ S/h (u·n)(v·n) ds: the penalty alone (inconsistent; for comparison)."""
    h = ufl.CellDiameter(ds.ufl_domain())
    return gamma * viscosity / h * ufl.dot(u, n) * ufl.dot(v, n) * ds
