"""Assembly of a linear system (A, b) from compiled forms with Dirichlet conditions."""

from __future__ import annotations

import time

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from dpcollapse import compat


def zero_dirichlet(sub: fem.FunctionSpace, facet_tags, tag: int):
    """The condition (sub-space component) = 0 on the facets tagged ``tag``."""
    mesh = sub.mesh
    facets = facet_tags.indices[facet_tags.values == tag]
    collapsed, _ = compat.collapse(sub)
    dofs = fem.locate_dofs_topological((sub, collapsed), mesh.topology.dim - 1, facets)
    return fem.dirichletbc(fem.Function(collapsed), dofs, sub)


class LinearSystem:
    """A matrix and a right-hand side built once and reassembled in place.

    ``homogeneous``: every condition of ``bcs`` prescribes zero (``zero_dirichlet``), so the
    lifting b ← b − A g of the right-hand side is zero and skipped (it costs a pass over
    the cells next to the conditions at every assembly)."""

    def __init__(self, a, L, bcs, homogeneous: bool = False):
        self.a = fem.form(a)
        self.L = fem.form(L)
        self.bcs = bcs
        self.homogeneous = homogeneous
        self.A = compat.create_matrix(self.a)
        self.b = compat.create_vector(self.L)
        self.seconds = {"assembly": 0.0}   # for benchmarks

    def assemble_matrix(self) -> PETSc.Mat:
        t0 = time.perf_counter()
        self.A.zeroEntries()
        fem_petsc.assemble_matrix(self.A, self.a, bcs=self.bcs)
        self.A.assemble()
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.A

    def assemble_vector(self) -> PETSc.Vec:
        t0 = time.perf_counter()
        with self.b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(self.b, self.L)
        if not self.homogeneous:
            fem_petsc.apply_lifting(self.b, [self.a], bcs=[self.bcs])
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.b, self.bcs)
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.b

    def solve(self, solver, target, b: PETSc.Vec | None = None) -> None:
        """Solve A x = b with ``solver`` (its operator already set) into Function ``target``
        (b: the last assembled right-hand side by default)."""
        solver.solve(self.b if b is None else b, compat.petsc_vec(target))
        target.x.scatter_forward()

    def load(self, x: PETSc.Vec, target) -> None:
        """Function ``target`` ← a vector ``x`` of this system's layout (owned values, ghosts
        updated): how a nonlinear solver hands its iterate to the forms."""
        compat.petsc_vec(target).array_w[:] = x.array_r
        target.x.scatter_forward()

    def store(self, source, x: PETSc.Vec) -> None:
        """Vector ``x`` of this system's layout ← Function ``source`` (owned values)."""
        x.array_w[:] = compat.petsc_vec(source).array_r

    def destroy(self) -> None:
        self.A.destroy()
        self.b.destroy()
