"""Assembly and solve of a linear system with a periodic (translation) constraint.

``PeriodicLinearSystem`` is a sibling of ``solvers.assembly.LinearSystem`` for a space V
(plain or mixed, e.g. Taylor–Hood) whose dofs on the facets tagged ``slave_tag`` are tied to
the values at their images under a translation: u(x_s) = u(x_s + translation). It wraps
dolfinx_mpc 0.5 (``MultiPointConstraint.create_periodic_constraint_topological``), whose
reduced system lives on ``mpc.function_space``; ``solve`` back-substitutes the slave dofs and
copies the result into a Function on the ORIGINAL space V, so every form whose coefficients
live on V (or on its collapsed subspaces) keeps working unchanged.

Where dolfinx_mpc is missing (the pip path), ``periodic_system`` builds the same
constrained system with PETSc alone (``solvers.periodic_petsc``); ``DPCOLLAPSE_PERIODIC``
(auto, dolfinx_mpc, petsc) forces one of the two.

Usage (the caller owns the solver and hands it the operator, as with ``LinearSystem``)::

    system = PeriodicLinearSystem(a, L, bcs, W, facet_tags, RIGHT, (-length, 0.0))
    A = system.assemble_matrix()
    b = system.assemble_vector()
    solver.set_operator(A)
    system.solve(solver, solution)          # solution: Function on W, ghosts updated

Layout facts checked for dolfinx_mpc 0.5 (``create_extended_functionspace``): the MPC space
shares V's dofmap list and owned range; its index map keeps V's ghosts in the same order
and appends, in parallel only, the off-process master dofs as extra ghosts (in serial it
is V's index map). Owned dofs therefore coincide; ``solve`` copies only the owned range and
scatters V's ghosts forward, which is correct whatever the ghost layout.

Corner dofs: the Dirichlet bcs are passed to the constraint, and dolfinx_mpc drops every
candidate slave dof that a bc constrains (per scalar component, see ``leaf_subspaces``), so
e.g. the bed/right-side corner under no-slip keeps its bc value instead of becoming a slave.
"""

from __future__ import annotations

import importlib.util
import os
import time
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from dpcollapse import compat
from dpcollapse.solvers.periodic_sides import leaf_subspaces, periodic_sides  # noqa: F401 (leaf_subspaces: re-exported)

#: Environment variable choosing the periodic constraint: "auto" (dolfinx_mpc where it is
#: installed, else ``solvers.periodic_petsc``), "dolfinx_mpc" or "petsc".
PERIODIC_ENV = "DPCOLLAPSE_PERIODIC"


def constraint_backend() -> str:
    """"dolfinx_mpc" or "petsc": the implementation ``periodic_system`` will use."""
    choice = os.environ.get(PERIODIC_ENV, "auto")
    if choice not in ("auto", "dolfinx_mpc", "petsc"):
        raise ValueError(f"{PERIODIC_ENV}={choice!r}: allowed auto, dolfinx_mpc, petsc")
    if choice == "auto":
        return "dolfinx_mpc" if importlib.util.find_spec("dolfinx_mpc") else "petsc"
    return choice


def periodic_system(a, L, bcs, V, facet_tags, slave_tag: int, translation, subspaces=None):
    """The periodic linear system of (a, L): ``PeriodicLinearSystem`` (dolfinx_mpc) or,
    where dolfinx_mpc is missing (the pip path), ``periodic_petsc.PeriodicPetscSystem``;
    the same contract and, for matching sides, the same constrained system."""
    if constraint_backend() == "dolfinx_mpc":
        return PeriodicLinearSystem(a, L, bcs, V, facet_tags, slave_tag, translation, subspaces)
    from dpcollapse.solvers.periodic_petsc import PeriodicPetscSystem

    return PeriodicPetscSystem(a, L, bcs, V, facet_tags, slave_tag, translation, subspaces)


class PeriodicLinearSystem:
    """A matrix and right-hand side with a periodic constraint, reassembled in place."""

    def __init__(self, a, L, bcs, V: fem.FunctionSpace, facet_tags, slave_tag: int,
                 translation: Sequence[float], subspaces=None):
        """Periodic u(x) = u(x + translation) for x on the facets tagged ``slave_tag``.

        ``translation`` maps a slave point onto its master (image) point, e.g. (−L, 0) ties
        the side x = L (slave) to x = 0 (master) of [0, L] × [0, h].
        ``subspaces``: the (sub)spaces to constrain; default every scalar leaf of V
        (``leaf_subspaces``), i.e. both velocity components and the pressure of a mixed
        space. Non-scalar entries are expanded into their leaves.
        ``bcs``: Dirichlet conditions on V (or its subspaces); they are applied in assembly
        and their dofs are never made slaves (corners shared with a no-slip bed keep the bc).
        """
        self.a = fem.form(a)
        self.L = fem.form(L)
        self.bcs = list(bcs)
        self.V = V
        mesh = V.mesh
        self.comm = mesh.comm
        shift, slave_facets, leaves = periodic_sides(V, facet_tags, slave_tag, translation,
                                                     subspaces)
        self.translation = shift
        fdim = mesh.topology.dim - 1

        def relation(x):
            return x + shift[:, None]

        import dolfinx_mpc

        mpc = dolfinx_mpc.MultiPointConstraint(V)
        for S in leaves:
            mpc.create_periodic_constraint_topological(S, facet_tags, slave_tag, relation, self.bcs)
        mpc.finalize()
        self.mpc = mpc
        self._check_slave_count(leaves, slave_facets, fdim)

        Vm = mpc.function_space
        self.function_space = Vm
        self.A = compat.mpc_create_matrix(self.a, mpc)
        self.b = compat.mpc_create_vector(mpc)
        self.seconds = {"assembly": 0.0}   # for benchmarks
        self.x = fem.Function(Vm)                   # reduced solution + back-substituted slaves
        self._owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        assert self._owned == Vm.dofmap.index_map.size_local * Vm.dofmap.index_map_bs

    # ------------------------------------------------------------------ checks
    def _check_slave_count(self, leaves, facets, fdim) -> None:
        """Every owned, non-Dirichlet dof on the slave facets must have become a slave."""
        marked = np.zeros(self._size_with_ghosts(), dtype=bool)
        for bc in self.bcs:
            dofs, _ = bc.dof_indices()
            marked[dofs] = True
        owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        expected = 0
        for S in leaves:
            if S is self.V:
                dofs = fem.locate_dofs_topological(S, fdim, facets)
            else:
                dofs = fem.locate_dofs_topological((S, compat.collapse(S)[0]), fdim, facets)[0]
            dofs = dofs[dofs < owned]
            expected += int(np.count_nonzero(~marked[dofs]))
        expected = self.comm.allreduce(expected, op=MPI.SUM)
        got = self.comm.allreduce(int(self.mpc.num_local_slaves), op=MPI.SUM)
        if got != expected:
            raise RuntimeError(f"periodic constraint made {got} slave dofs, expected {expected}: "
                               "some images of slave dofs were not found in the mesh")

    def _size_with_ghosts(self) -> int:
        im = self.V.dofmap.index_map
        return (im.size_local + im.num_ghosts) * self.V.dofmap.index_map_bs

    # ------------------------------------------------------------------ assembly
    def assemble_matrix(self) -> PETSc.Mat:
        """Reduced matrix: slave rows/cols folded onto their masters, 1 on the slave and
        bc diagonals (dolfinx_mpc.assemble_matrix does zeroEntries and final assembly)."""
        import dolfinx_mpc

        t0 = time.perf_counter()
        dolfinx_mpc.assemble_matrix(self.a, self.mpc, bcs=self.bcs, A=self.A)
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.A

    def assemble_vector(self) -> PETSc.Vec:
        """Reduced right-hand side, lifted by the bcs, bc values set on owned bc dofs."""
        import dolfinx_mpc

        t0 = time.perf_counter()
        dolfinx_mpc.assemble_vector(self.L, self.mpc, b=self.b)   # zeroes b (incl. ghosts)
        dolfinx_mpc.apply_lifting(self.b, [self.a], [self.bcs], self.mpc)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.b, self.bcs)
        self.seconds["assembly"] += time.perf_counter() - t0
        return self.b

    # ------------------------------------------------------------------ solve
    def solve(self, solver, target: fem.Function, b: PETSc.Vec | None = None) -> None:
        """Solve A x = b and write the periodic solution into ``target`` (a Function on V).

        ``solver`` is any object with ``solve(b, x)`` whose operator the caller has already
        set to ``assemble_matrix()``'s result (e.g. ``DirectSolver.set_operator(A)``);
        ``b`` defaults to the vector of the last ``assemble_vector()``. The slave values are
        recovered by back-substitution (x_s = Σ c_sm x_m) and ``target``'s ghosts updated.
        """
        if target.function_space is not self.V and target.x.array.size != self._size_with_ghosts():
            raise ValueError("target must be a Function on the original space V")
        x = compat.petsc_vec(self.x)
        solver.solve(self.b if b is None else b, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        compat.mpc_homogenize(self.mpc, self.x)        # backsubstitution adds (+=) onto slaves
        compat.mpc_backsubstitution(self.mpc, self.x)  # slaves (owned and ghost) from masters
        n = self._owned
        target.x.array[:n] = self.x.x.array[:n]
        target.x.scatter_forward()

    def load(self, x: PETSc.Vec, target: fem.Function) -> None:
        """Function ``target`` on V ← a reduced vector ``x`` (the owned masters), the slaves
        back-substituted from their masters: how a nonlinear solver hands its iterate to
        the forms (its slave entries are not used)."""
        n = self._owned
        compat.petsc_vec(self.x).array_w[:n] = x.array_r[:n]
        self.x.x.scatter_forward()
        compat.mpc_homogenize(self.mpc, self.x)
        compat.mpc_backsubstitution(self.mpc, self.x)
        target.x.array[:n] = self.x.x.array[:n]
        target.x.scatter_forward()

    def store(self, source: fem.Function, x: PETSc.Vec) -> None:
        """Reduced vector ``x`` ← Function ``source`` on V (owned values; same owned layout)."""
        n = self._owned
        x.array_w[:n] = source.x.array[:n]

    def destroy(self) -> None:
        self.A.destroy()
        self.b.destroy()
