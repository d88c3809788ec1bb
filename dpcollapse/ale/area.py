"""The area a mesh move loses, put back (``numerics.step_conserve_area``).

Moving the nodes by Δt·w (P1 w, straight-sided cells) changes the area of Ω exactly by

    A(x + Δt w) − A(x) = Δt ∫ div w dx + Δt² ∫ det ∇w dx,

the first term Δt ∮ w·n ds = Δt ∮ (w − u)·n ds (the penalized kinematic condition's
residual: ∮ u·n ds = ∫ div u dx = 0 for the Taylor–Hood velocity, whose P1 pressure tests
div u with q = 1), the second the explicit update's own error: for an incompressible w,
det ∇w = −(∂ₓw_x)² − ∂ᵧw_x ∂ₓw_y ≤ 0 in a spreading (extensional) flow, so a collapse loses
area at every step, O(Δt²) each, O(Δt) over a run (measured on the a = 1.42 column:
docs/benchmarks/2026-12-07-moving-mesh-front-film.md). A closed mass keeps its area, so the
change is put back after the move by displacing the free-surface nodes by s·N_i, with

    N_i = ∫_{Γ_f} φ_i n ds     (the area's first variation: moving node i by δ adds N_i·δ),

and s the root nearest 0 of the quadratic A(s) = A_before (each cell's area is quadratic in
its nodes, so three evaluations give A(s) exactly). Nodes on a solid side (bed, wall) and
free-surface nodes on the bed y = 0 (a landed nose) are not moved. s is O(Δt² |∇w|² A/|Γ_f|)
(of order 1e-7 m on that column): the surface moves by far less than a cell, in its normal
direction, and the step's first-order motion is unchanged.

Axisymmetric (``geometry.symmetry: axisymmetric``, x = r ≥ 0): the measure kept is the
body's volume V = 2π ∫ r dA instead of the area. The same move changes it by

    V(x + Δt w) − V(x) = Δt ∫ div_rz(w) 2πr dA + O(Δt²),   div_rz w = ∂_r w_r + w_r/r + ∂_z w_z

(a cell's volume 2π |T| r̄_T, r̄_T the mean radius of its nodes, is cubic in its nodes: the
remainder is Δt² and Δt³ terms, again non-zero for an incompressible w: the extensional
w = ε(r, −2z) scales V by (1 + εΔt)²(1 − 2εΔt)). The first variation of V carries the
weight r, δV = ∮ 2πr n·δx ds, so the directions are

    N_i = ∫_{Γ_f} 2πr φ_i n ds,

and s solves V(s) = V_before: the root nearest 0 of the quadratic through V(0), V(±s₁)
(s₁ the linear estimate; the cubic term leaves O(s₁³) ≈ 1e-21 m³ at s₁ ~ 1e-7 m), refined
by secant steps to round-off. Nodes on the axis r = 0 are on a solid side and stay.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from dpcollapse import compat
from dpcollapse.ale.quality import signed_areas

#: Secant refinements of the root s after the quadratic's (axisymmetric: V(s) is cubic).
SECANT_STEPS = 3


class AreaKeeper:
    """Put back the area change of a move of ``mesh`` (free surface: facets tagged in
    ``surface_tags``; nodes of the other tagged facets stay). ``axisymmetric``: the measure
    kept is the volume 2π∫ r dA of the body of revolution about x = 0 [m³]."""

    #: the measure kept: the area (planar) or the volume 2π∫ r dA (axisymmetric)
    axisymmetric = False

    def __init__(self, mesh, facet_tags, surface_tags, space, node_dof: np.ndarray,
                 cells: np.ndarray, axisymmetric: bool = False):
        self.mesh, self.space = mesh, space
        self.axisymmetric = axisymmetric
        self._node_dof, self._cells = node_dof, cells
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
        ds_surface = sum((ds(t) for t in surface_tags[1:]), ds(surface_tags[0]))
        n = ufl.FacetNormal(mesh)
        # the first variation of the measure: δA = ∮ n·δx ds, δV = ∮ 2πr n·δx ds
        variation = ufl.dot(n, ufl.TestFunction(space))
        if axisymmetric:
            variation = 2 * math.pi * ufl.SpatialCoordinate(mesh)[0] * variation
        self._variation = fem.form(variation * ds_surface)
        self._N = fem.Function(space)
        fixed = facet_tags.indices[~np.isin(facet_tags.values, surface_tags)]
        self._fixed = np.unique(compat.entities_to_geometry(mesh, 1, fixed).ravel())
        owned = compat.num_owned_cells(mesh)
        self._owned = cells[:owned]
        self._sign = np.sign(signed_areas(mesh.geometry.x[:, :2][self._owned]))

    def area(self, x: np.ndarray | None = None) -> float:
        """Area of the mesh [m²] (global), at node coordinates ``x`` (default: the current);
        axisymmetric: the volume Σ_T 2π |T| r̄_T [m³] (r̄_T the mean radius of T's nodes:
        Pappus, exact for a straight-sided cell)."""
        x = self.mesh.geometry.x if x is None else x
        cells = x[:, :2][self._owned]
        areas = 0.5 * self._sign * signed_areas(cells)
        if self.axisymmetric:
            areas = 2 * math.pi * areas * cells[:, :, 0].mean(axis=1)
        return self.mesh.comm.allreduce(float(np.sum(areas)), op=MPI.SUM)

    def directions(self) -> np.ndarray:
        """N_i at every geometry node (num_nodes, 2): zero off the free surface, on solid
        sides and on the bed y = 0."""
        vec = compat.petsc_vec(self._N)
        with vec.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(vec, self._variation)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        N = self._N.x.array.reshape(-1, 2)[self._node_dof].copy()
        N[self._fixed] = 0.0
        N[self.mesh.geometry.x[:, 1] == 0.0] = 0.0
        return N

    def restore(self, target: float) -> float:
        """Displace the free surface along N so that the area is ``target`` [m²] again;
        returns the area change put back (target − area before)."""
        x = self.mesh.geometry.x
        a0 = self.area()
        missing = target - a0
        if missing == 0.0:
            return 0.0
        N = self.directions()
        first = self.mesh.comm.allreduce(float(np.sum(N * N)), op=MPI.SUM)
        if not first > 0.0:
            return 0.0
        scale = missing / first           # the linear estimate of s
        start = x[:, :2].copy()

        def area_at(s: float) -> float:
            x[:, :2] = start + s * N
            return self.area()

        plus, minus = area_at(scale), area_at(-scale)
        b = (plus - minus) / (2 * scale)          # A(s) = a0 + b s + c s²
        c = (plus + minus - 2 * a0) / (2 * scale * scale)
        s = _root_nearest_zero(c, b, a0 - target, scale)
        if self.axisymmetric:      # V(s) is cubic: secant steps from the quadratic's root
            s_prev, v_prev = 0.0, a0
            for _ in range(SECANT_STEPS):
                v = area_at(s)
                if v == target or v == v_prev:
                    break
                s, s_prev, v_prev = s - (v - target) * (s - s_prev) / (v - v_prev), s, v
        x[:, :2] = start + s * N
        return missing


def _root_nearest_zero(c: float, b: float, d: float, fallback: float) -> float:
    """The root of c s² + b s + d nearest 0 (the linear one when c s² is negligible)."""
    if b == 0.0:
        return fallback
    disc = b * b - 4 * c * d
    if c == 0.0 or disc < 0.0:
        return -d / b
    q = -0.5 * (b + math.copysign(math.sqrt(disc), b))   # the stable form
    return d / q if q != 0.0 else -d / b
