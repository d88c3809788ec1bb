"""The granular volume fraction c (DG0) of the two-phase model: its initial value and its
explicit, sub-cycled, conservative advection (``forms.two_phase``).

* ``rectangle_fraction``: c_K = |K ∩ R| / |K| for a rectangle R, exact (each triangle is
  clipped against the four sides of R, Sutherland–Hodgman, and the clipped polygon's area
  taken by the shoelace formula);
* ``VolumeFraction``: c, and ``advance(dt)``: N sub-steps of
  c_K ← c_K − (Δt/N)/|K| ∫_∂K (F_upwind + F_compression) ds, with N the smallest count such
  that (Δt/N) max_K ∫_∂K ((u·n)⁺ + C|u·n|) ds / |K| ≤ the Courant number. Under MPI the facet
  integrals of the cells on the partition boundary are summed by a reverse scatter and the
  ghost values of c updated by a forward scatter after every sub-step.
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
from dpcollapse.forms.two_phase import compression_flux, fraction_flux, outflow_rate


def _clip(poly: list, axis: int, bound: float, keep_below: bool) -> list:
    """The part of the polygon ``poly`` (list of (x, y)) on one side of x_axis = bound."""
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ina = a[axis] <= bound if keep_below else a[axis] >= bound
        inb = b[axis] <= bound if keep_below else b[axis] >= bound
        if ina:
            out.append(a)
        if ina != inb:
            s = (bound - a[axis]) / (b[axis] - a[axis])
            out.append((a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])))
    return out


def _area(poly: list) -> float:
    if len(poly) < 3:
        return 0.0
    p = np.asarray(poly)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def rectangle_fraction(triangles: np.ndarray, lower, upper) -> np.ndarray:
    """|K ∩ R| / |K| for each triangle K of ``triangles`` (n, 3, 2) and the rectangle
    R = [lower, upper] (exact up to round-off)."""
    out = np.zeros(len(triangles))
    for k, tri in enumerate(np.asarray(triangles, dtype=float)):
        poly = [tuple(p) for p in tri]
        for axis in (0, 1):
            poly = _clip(poly, axis, lower[axis], keep_below=False)
            if poly:
                poly = _clip(poly, axis, upper[axis], keep_below=True)
            if not poly:
                break
        whole = _area([tuple(p) for p in tri])
        out[k] = _area(poly) / whole if whole > 0 else 0.0
    return np.clip(out, 0.0, 1.0)


def owned_triangles(mesh) -> np.ndarray:
    """(n_owned, 3, 2) vertex coordinates of the owned cells."""
    n = compat.num_owned_cells(mesh)
    return mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n, :3]]


class VolumeFraction:
    """c on DG0 and its advection by a velocity given by ``bind(u)`` (a UFL vector on the same
    mesh; the flow's forms need c before its velocity exists)."""

    def __init__(self, mesh, courant: float, compression: float):
        self.mesh, self.comm = mesh, mesh.comm
        self.courant, self.compression = courant, compression
        self.S0 = S0 = compat.scalar_space(mesh, 0, "DG")
        self.c = fem.Function(S0, name="volume_fraction")   # cⁿ (accepted)
        self.work = fem.Function(S0)                         # c during the sub-steps
        self.pending = None                                  # c^{n+1} of a converged step
        self.substeps = 0                                    # of the last advance
        self._n = S0.dofmap.index_map.size_local
        v = ufl.TestFunction(S0)
        cell = fem.form(v * ufl.dx(domain=mesh))
        volume = compat.create_vector(cell)
        fem_petsc.assemble_vector(volume, cell)
        volume.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.volume = volume.array_r[:self._n].copy()       # |K| of the owned cells
        volume.destroy()
        self._integral = fem.form(self.c * ufl.dx(domain=mesh))
        self._b = None

    def bind(self, u) -> None:
        """Build the flux and rate forms for the velocity ``u``."""
        mesh, C = self.mesh, self.compression
        v = ufl.TestFunction(self.S0)
        n = ufl.FacetNormal(mesh)
        dS, ds = ufl.dS(domain=mesh), ufl.ds(domain=mesh)
        flux = fraction_flux(self.work, u, v, n, dS, ds)
        if C > 0:
            flux = flux + compression_flux(self.work, u, v, n, dS, C)
        self._flux = fem.form(flux)
        self._rate = fem.form(outflow_rate(u, v, n, dS, ds, C))
        self._divergence = fem.form(ufl.div(u) * v * ufl.dx(domain=mesh))
        self._b = compat.create_vector(self._flux)

    def set_values(self, owned_values: np.ndarray) -> None:
        """cⁿ of the owned cells (in dof order); ghosts updated."""
        self.c.x.array[:self._n] = owned_values
        self.c.x.scatter_forward()

    def _assemble(self, form) -> np.ndarray:
        b = self._b
        with b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(b, form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return b.array_r[:self._n]

    def max_rate(self) -> float:
        """max_K ∫_∂K ((u·n)⁺ + C|u·n|) ds / |K| [1/s] for the current u."""
        local = self._assemble(self._rate) / self.volume
        top = float(local.max()) if len(local) else 0.0
        return self.comm.allreduce(top, op=MPI.MAX)

    def divergence_rate(self) -> float:
        """Σ_K min(c_K, 1) |∫_K ∇·u dx| [m²/s]: the rate at which the cellwise divergence of
        the velocity makes or unmakes granular volume in the upwind fluxes (zero for an
        exactly divergence-free u; the light fluid's cells do not count)."""
        weight = np.clip(self.c.x.array[:self._n], 0.0, 1.0)
        local = float((weight * np.abs(self._assemble(self._divergence))).sum())
        return self.comm.allreduce(local, op=MPI.SUM)

    def advance(self, dt: float) -> int:
        """c^{n+1} from cⁿ with the current u (kept as ``pending``); the number of sub-steps."""
        rate = self.max_rate()
        steps = max(1, math.ceil(dt * rate / self.courant - 1e-12)) if rate > 0 else 1
        h = dt / steps
        self.work.x.array[:] = self.c.x.array
        for _ in range(steps):
            residual = self._assemble(self._flux)
            self.work.x.array[:self._n] -= h * residual / self.volume
            self.work.x.scatter_forward()
        self.pending = self.work.x.array.copy()
        self.substeps = steps
        return steps

    def accept(self) -> None:
        if self.pending is not None:
            self.c.x.array[:] = self.pending
        self.pending = None

    def reject(self) -> None:
        self.pending = None

    def integral(self) -> float:
        """∫ c dx [m²]."""
        return self.comm.allreduce(fem.assemble_scalar(self._integral), op=MPI.SUM)

    def bounds(self) -> tuple[float, float]:
        """(min c, max c) over all cells."""
        own = self.c.x.array[:self._n]
        lo = float(own.min()) if len(own) else math.inf
        hi = float(own.max()) if len(own) else -math.inf
        return self.comm.allreduce(lo, op=MPI.MIN), self.comm.allreduce(hi, op=MPI.MAX)

    def destroy(self) -> None:
        if self._b is not None:
            self._b.destroy()
