"""A periodic (translation) constraint with PETSc alone, where dolfinx_mpc is missing.

The same contract as ``solvers.periodic.PeriodicLinearSystem`` (dolfinx_mpc): u(x_s) =
u(x_s + t) for every dof x_s on the facets tagged ``slave_tag``, applied to the system
assembled on the ORIGINAL space V. It relies on the slave and master dofs sitting at the
same points up to the translation (a mesh whose two sides match node for node, as the
structured layer's do); a dof whose image is not a dof of the same (scalar) subspace is an
error, not an approximation.

With P the prolongation (n × n, in V's layout) P[i, i] = 1 for every non-slave dof and
P[s, m(s)] = 1 for a slave s and its master m(s) (P[s, s] = 0, stored, so that the
product keeps the slave diagonals in its sparsity), the constrained system is

    K = Pᵀ A P + S,     r = Pᵀ b,     x = P y   where K y = r,

with A, b the ordinary assembled matrix and vector (Dirichlet rows and columns already
eliminated, ``solvers.assembly.LinearSystem``) and S the identity on the slave rows (whose
rows and columns of Pᵀ A P are zero): each master row gathers its slave's equation, the
slave unknowns are dummies with y_s = 0, and x_s = y_m(s). This is what dolfinx_mpc's
assembly computes for a periodic constraint with unit coefficients; its reduced space is
V's layout too, so ``load``/``store``/``solve`` have the same meaning.

Slave candidates that a Dirichlet condition constrains (per scalar component) are left
alone, and so is a pair whose master a condition constrains, so the corners of a no-slip
bed keep their bc.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from dpcollapse import compat
from dpcollapse.solvers.assembly import LinearSystem
from dpcollapse.solvers.periodic_sides import periodic_sides


def _global_indices(V, local: np.ndarray) -> np.ndarray:
    """Global (unrolled) indices of V's local (unrolled) dof indices."""
    im, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    local = np.asarray(local, dtype=np.int64)
    blocks = im.local_to_global((local // bs).astype(np.int32))
    return np.asarray(blocks, dtype=np.int64) * bs + local % bs


class PeriodicPetscSystem:
    """A matrix and right-hand side with a periodic constraint, by Pᵀ A P (no dolfinx_mpc)."""

    def __init__(self, a, L, bcs, V: fem.FunctionSpace, facet_tags, slave_tag: int,
                 translation: Sequence[float], subspaces=None):
        """Arguments as ``solvers.periodic.PeriodicLinearSystem``'s."""
        self.full = LinearSystem(a, L, list(bcs))
        self.a, self.L, self.bcs = self.full.a, self.full.L, self.full.bcs
        self.V = V
        self.function_space = V
        mesh = V.mesh
        self.comm = mesh.comm
        gdim = mesh.geometry.dim
        shift, slave_facets, leaves = periodic_sides(V, facet_tags, slave_tag, translation,
                                                     subspaces)
        self.translation = shift
        fdim = mesh.topology.dim - 1

        im, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        self._owned = im.size_local * bs
        fixed = np.zeros((im.size_local + im.num_ghosts) * bs, dtype=bool)
        for bc in self.bcs:
            fixed[bc.dof_indices()[0]] = True
        pairs = self._match(leaves, slave_facets, fdim, gdim, fixed)
        self.num_local_slaves = len(pairs)
        self.P = self._prolongation(pairs)
        self.slave_diagonal = self.full.b.duplicate()   # 1 on the owned slave rows
        self.slave_diagonal.set(0.0)
        first = im.local_range[0] * bs
        self.slave_diagonal.array_w[(pairs[:, 0] - first).astype(np.int32)] = 1.0
        self.A = None
        self.b = self.full.b.duplicate()
        self.x = self.full.b.duplicate()
        self.seconds = {"assembly": 0.0}   # for benchmarks
        self.assemble_matrix()   # K's sparsity now (SNES takes ``A`` before assembling it)

    # ------------------------------------------------------------------ the dof map
    def _match(self, leaves, facets, fdim, gdim, fixed) -> np.ndarray:
        """(owned slave, master) global index pairs: every owned, non-Dirichlet dof on the
        slave facets with the dof of the same leaf at its translated point."""
        V, comm = self.V, self.comm
        tol = 1e-8 * max(float(np.max(np.abs(self.translation))), 1.0)
        images, slaves, masters_here = [], [], []
        for k, S in enumerate(leaves):
            if S is V:   # a scalar space: its own collapsed space
                Sc, parent = V, np.arange(fixed.size, dtype=np.int64)
                on_side = fem.locate_dofs_topological(V, fdim, facets)
            else:
                Sc, parent = compat.collapse(S)
                on_side = fem.locate_dofs_topological((S, Sc), fdim, facets)[1]
            X = Sc.tabulate_dof_coordinates()[:, :gdim]
            on_side = np.asarray(on_side, dtype=np.int64)
            dofs = parent[on_side]
            keep = (dofs < self._owned) & ~fixed[dofs]
            slaves.append(np.c_[np.full(keep.sum(), k), _global_indices(V, dofs[keep])])
            images.append(X[on_side[keep]] + self.translation[:gdim])
            owned = parent < self._owned
            masters_here.append((k, X[owned], _global_indices(V, parent[owned]),
                                 fixed[parent[owned]]))
        slaves = np.concatenate(slaves) if slaves else np.zeros((0, 2), dtype=np.int64)
        images = np.concatenate(images) if images else np.zeros((0, gdim))
        # every rank looks for every slave's image among its owned dofs of the same leaf
        all_slaves = np.concatenate(comm.allgather(slaves))
        all_images = np.concatenate(comm.allgather(images))
        found = []
        for k, X, glob, is_fixed in masters_here:
            mine = np.flatnonzero(all_slaves[:, 0] == k)
            if not len(mine) or not len(X):
                continue
            dist, idx = cKDTree(X).query(all_images[mine], distance_upper_bound=tol)
            hit = np.isfinite(dist)
            found.append(np.c_[all_slaves[mine[hit], 1], glob[idx[hit]], is_fixed[idx[hit]]])
        found = np.concatenate(found) if found else np.zeros((0, 3), dtype=np.int64)
        found = np.concatenate(comm.allgather(found))
        pairs = found[np.isin(found[:, 0], slaves[:, 1])]
        expected = comm.allreduce(len(slaves), op=MPI.SUM)
        if comm.allreduce(len(np.unique(pairs[:, 0])), op=MPI.SUM) != expected or \
                comm.allreduce(len(pairs), op=MPI.SUM) != expected:
            raise RuntimeError(
                f"periodic constraint: {expected} slave dofs, but their images are not each "
                "one dof of the same subspace (the two sides' nodes must match)")
        if np.any(np.isin(pairs[:, 1], all_slaves[:, 1])):
            raise RuntimeError("periodic constraint: a master dof is itself a slave")
        return pairs[pairs[:, 2] == 0][:, :2]   # a master fixed by a bc: the slave stays free

    def _prolongation(self, pairs: np.ndarray) -> PETSc.Mat:
        """P: identity on the non-slave rows, 0 on the slave diagonals, 1 at (s, m(s))."""
        V = self.V
        n_local = self._owned
        n_global = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        first = V.dofmap.index_map.local_range[0] * V.dofmap.index_map_bs
        is_slave = np.zeros(n_local, dtype=bool)
        master = np.zeros(n_local, dtype=np.int64)
        local = (pairs[:, 0] - first).astype(np.int64)
        is_slave[local] = True
        master[local] = pairs[:, 1]
        rows = first + np.arange(n_local, dtype=np.int64)
        counts = np.where(is_slave, 2, 1)
        indptr = np.r_[0, np.cumsum(counts)].astype(PETSc.IntType)
        cols = np.empty(indptr[-1], dtype=np.int64)
        vals = np.empty(indptr[-1], dtype=PETSc.ScalarType)
        start = indptr[:-1]
        cols[start[~is_slave]] = rows[~is_slave]
        vals[start[~is_slave]] = 1.0
        s_start = start[is_slave]
        lo = np.minimum(rows[is_slave], master[is_slave])
        hi = np.maximum(rows[is_slave], master[is_slave])
        cols[s_start], cols[s_start + 1] = lo, hi          # sorted within the row
        vals[s_start] = np.where(lo == rows[is_slave], 0.0, 1.0)
        vals[s_start + 1] = np.where(hi == rows[is_slave], 0.0, 1.0)
        P = PETSc.Mat().createAIJ(((n_local, n_global), (n_local, n_global)),
                                  csr=(indptr, cols.astype(PETSc.IntType), vals), comm=self.comm)
        P.assemble()
        return P

    # ------------------------------------------------------------------ assembly
    def assemble_matrix(self) -> PETSc.Mat:
        """K = Pᵀ A P + S (the same Mat object after the first call)."""
        t0 = time.perf_counter()
        A = self.full.assemble_matrix()
        self.A = A.PtAP(self.P, result=self.A)
        self.A.setDiagonal(self.slave_diagonal, addv=PETSc.InsertMode.ADD_VALUES)
        self.A.assemble()
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.A

    def assemble_vector(self) -> PETSc.Vec:
        """r = Pᵀ b, b lifted by the bcs with the bc values on the bc rows."""
        t0 = time.perf_counter()
        self.P.multTranspose(self.full.assemble_vector(), self.b)
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.b

    # ------------------------------------------------------------------ solve
    def solve(self, solver, target: fem.Function, b: PETSc.Vec | None = None) -> None:
        """Solve K y = r and write x = P y (slaves from their masters) into ``target``."""
        solver.solve(self.b if b is None else b, self.x)
        self.load(self.x, target)

    def load(self, x: PETSc.Vec, target: fem.Function) -> None:
        """Function ``target`` on V ← P x (its slave entries from their masters)."""
        self.P.mult(x, compat.petsc_vec(target))
        target.x.scatter_forward()

    def store(self, source: fem.Function, x: PETSc.Vec) -> None:
        """Vector ``x`` ← Function ``source`` (owned values; the same layout)."""
        x.array_w[:] = source.x.array[:self._owned]

    def destroy(self) -> None:
        for obj in (self.A, self.b, self.x, self.P, self.slave_diagonal):
            if obj is not None:
                obj.destroy()
        self.full.destroy()
