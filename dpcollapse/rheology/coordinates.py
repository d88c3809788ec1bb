"""The coordinates of the 2D model: planar (x, y) or axisymmetric (r, z) (``geometry.symmetry``).

Planar (a slice of unit depth)::

    D(u) = (∇u + ∇uᵀ)/2 (2×2),   ∇·u = ∂_x u_x + ∂_y u_y,   ∫ f dx

Axisymmetric, a body of revolution about the axis x = r = 0 with y = z and no swirl
(u = u_r e_r + u_z e_z, u_θ = 0)::

             ⎡ ∂_r u_r               (∂_z u_r + ∂_r u_z)/2   0     ⎤
    D(u) =   ⎢ (∂_z u_r + ∂_r u_z)/2  ∂_z u_z                0     ⎥   (3×3: the hoop rate u_r/r)
             ⎣ 0                     0                      u_r/r ⎦

    ∇·u = ∂_r u_r + u_r/r + ∂_z u_z,    ∫_{body} f dV = ∫_Ω f 2πr dx,   ∫_{surface} f dA = ∫_Γ f 2πr ds

so |D|² = D:D (Frobenius, the project's norm) includes (u_r/r)², and the yield stress and
μ(I)'s inertial number see the hoop rate. Every integral of the weak form is taken with the
weight 2πr (``measure``); on the axis r = 0 the weight vanishes and u_r = 0 is imposed
strongly (a slip side with no friction), so u_r/r stays bounded there.

The planar object returns exactly the UFL of before (``ufl.sym(ufl.grad(u))``, ``ufl.div``,
the measure itself), so the planar forms are unchanged bit for bit.
"""

from __future__ import annotations

import math

import ufl
from ufl.domain import extract_unique_domain

#: the values of ``geometry.symmetry``
SYMMETRIES = ("planar", "axisymmetric")


class WeightedMeasure:
    """A UFL measure times a weight: ``integrand * WeightedMeasure(dx, w)`` is
    ``(integrand * w) * dx``; calling it (``ds(tag)``) or adding two keeps the weight."""

    def __init__(self, measure, weight):
        self.measure = measure
        self.weight = weight

    def __rmul__(self, integrand):
        return (integrand * self.weight) * self.measure

    def ufl_domain(self):
        """The mesh of the measure (as ``ufl.Measure.ufl_domain``: Nitsche's cell size)."""
        return self.measure.ufl_domain()

    def __call__(self, *args, **kwargs) -> WeightedMeasure:
        return WeightedMeasure(self.measure(*args, **kwargs), self.weight)

    def __add__(self, other: WeightedMeasure) -> WeightedMeasure:
        if not isinstance(other, WeightedMeasure) or other.weight is not self.weight:
            return NotImplemented
        return WeightedMeasure(self.measure + other.measure, self.weight)


class Planar:
    """(x, y): D(u) = sym ∇u, ∇·u = div u, the measure unweighted."""

    name = "planar"
    #: the rank of the strain-rate tensor
    dimension = 2

    def strain_rate(self, u):
        """D(u) = (∇u + ∇uᵀ)/2."""
        return ufl.sym(ufl.grad(u))

    def divergence(self, u):
        """∇·u = ∂_x u_x + ∂_y u_y."""
        return ufl.div(u)

    def measure(self, measure, mesh=None):
        """The measure itself: ∫ f dx."""
        return measure

    def in_plane(self, tensor):
        """The (x, y) block of a tensor of ``strain_rate``'s shape: the tensor itself."""
        return tensor

    def __repr__(self) -> str:
        return "Planar()"

    def __eq__(self, other) -> bool:
        return type(other) is type(self)

    def __hash__(self) -> int:
        return hash(self.name)


class Axisymmetric(Planar):
    """(r, z) = (x, y), the axis at x = 0: D(u) with the hoop rate u_r/r, ∇·u with u_r/r,
    the measure weighted by 2πr."""

    name = "axisymmetric"
    dimension = 3

    @staticmethod
    def radius(expression):
        """r = x of the mesh of a UFL expression [m]."""
        return ufl.SpatialCoordinate(extract_unique_domain(expression))[0]

    def strain_rate(self, u):
        """D(u) as the 3×3 tensor of the module docstring (the hoop entry u_r/r)."""
        g = ufl.grad(u)
        hoop = u[0] / self.radius(u)
        shear = 0.5 * (g[0, 1] + g[1, 0])
        return ufl.as_tensor([[g[0, 0], shear, 0], [shear, g[1, 1], 0], [0, 0, hoop]])

    def divergence(self, u):
        """∇·u = ∂_r u_r + u_r/r + ∂_z u_z."""
        return ufl.div(u) + u[0] / self.radius(u)

    def measure(self, measure, mesh=None):
        """2πr times ``measure`` (``mesh`` gives r when the measure has no domain)."""
        domain = measure.ufl_domain() if mesh is None else mesh
        if domain is None:
            raise ValueError("an axisymmetric measure needs its mesh")
        r = ufl.SpatialCoordinate(domain)[0]
        return WeightedMeasure(measure, 2.0 * math.pi * r)

    def in_plane(self, tensor):
        """The (r, z) block of a 3×3 tensor (the normal stress on a side in the plane)."""
        return ufl.as_tensor([[tensor[0, 0], tensor[0, 1]], [tensor[1, 0], tensor[1, 1]]])

    def __repr__(self) -> str:
        return "Axisymmetric()"


PLANAR = Planar()
AXISYMMETRIC = Axisymmetric()


def coordinates(symmetry: str) -> Planar:
    """The coordinates of ``geometry.symmetry`` (planar or axisymmetric)."""
    if symmetry not in SYMMETRIES:
        raise ValueError(f"symmetry = {symmetry!r}: must be one of {', '.join(SYMMETRIES)}")
    return AXISYMMETRIC if symmetry == "axisymmetric" else PLANAR
