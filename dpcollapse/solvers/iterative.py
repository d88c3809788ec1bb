"""Iterative solve of the Taylor–Hood saddle-point system: FGMRES + Schur fieldsplit.

The monolithic matrix of W = V × Q, split by the owned velocity and pressure dofs,

    K = [A  Bᵀ]     A: inertia ρ/Δt M_u + convection + viscoplastic ν D(u):D(v) (+ friction),
        [B  0 ]     B: −∫ q div u,

is solved by flexible GMRES (right preconditioning: the test is on the true residual,
‖b − Kx‖ ≤ rtol ‖b‖; the last iterate is the initial guess) with the block upper-triangular
preconditioner of PETSc's ``PCFIELDSPLIT`` (Schur factorization ``upper``)

    P = [Â  Bᵀ]     Â⁻¹: one BoomerAMG V-cycle (hypre; HMIS coarsening, ext+i interpolation,
        [0  Ŝ ]          strength 0.5, aggressive coarsening on the first level; the velocity
                         index set has block size 2, so the AMG sees 2×2 nodal blocks),

and the Schur complement S = −B A⁻¹ Bᵀ approximated à la Cahouet–Chabard,

    Ŝ⁻¹ = −(M_ν⁻¹ + L⁻¹),   M_ν = ∫ (2/ν) p q dx,   L = ∫ (Δt/ρ) ∇p·∇q dx (p = 0 on the
                                                           free surface),

M_ν⁻¹ by its diagonal and L⁻¹ by one BoomerAMG V-cycle (where PETSc has no hypre, the pip
path's wheel: PETSc's GAMG for both V-cycles, ``compat.amg_type``): ν/2 is the Stokes viscosity of the
secant iterate (−B(−div ν D)⁻¹Bᵀ ≈ −M_ν where viscosity dominates), and where inertia
dominates −B(ρ/Δt M_u)⁻¹Bᵀ ≈ −(Δt/ρ) L. The viscosity-weighted mass matrix alone (with a
cell-local ρh²/Δt term) needed 193 (1 cm) and 317 (0.5 cm) iterations on the first solve
of a collapse (p = 0, ν = 2η: the inertial limit), against 19 and 15 with L (lower
factorization). M_ν and L are reassembled from their UFL forms at every ``set_operator``.

Limit (measured, docs/benchmarks/2026-11-24-iterative-solver.md): with an exact velocity solve the Schur
approximation takes 16 iterations whatever ε, but the AMG V-cycle on A degrades with the
viscosity contrast of a developed flow (flowing ν ~ 10–100 Pa s next to rigid ν ~ κ/ε):
at ε = 1e-6 FGMRES does not converge in 500 iterations there.
"""

from __future__ import annotations

import time

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from dpcollapse import compat

#: Defaults of the outer Krylov solve: relative residual and iteration cap.
RTOL = 1e-10
MAX_IT = 500

#: PETSc options (under the solver's prefix) set unless the user gave them.
DEFAULT_OPTIONS = {
    "fieldsplit_u_ksp_type": "preonly",
    "fieldsplit_u_pc_type": "hypre",
    "fieldsplit_u_pc_hypre_type": "boomeramg",
    "fieldsplit_u_pc_hypre_boomeramg_coarsen_type": "HMIS",
    "fieldsplit_u_pc_hypre_boomeramg_interp_type": "ext+i",
    "fieldsplit_u_pc_hypre_boomeramg_strong_threshold": 0.5,
    "fieldsplit_u_pc_hypre_boomeramg_agg_nl": 1,
    "fieldsplit_p_ksp_type": "preonly",
}
#: The same where PETSc has no hypre (the pip path's wheel): one V-cycle of PETSc's GAMG.
GAMG_OPTIONS = {
    "fieldsplit_u_ksp_type": "preonly",
    "fieldsplit_u_pc_type": "gamg",
    "fieldsplit_p_ksp_type": "preonly",
}


class BlockSolver:
    """FGMRES with a Schur-complement fieldsplit preconditioner, kept across solves.

    ``mass_form``, ``laplacian_form``: bilinear forms on W coupling only the pressure
    trial/test functions (M_ν and L above, ``laplacian_bcs`` on L); their (p, p) blocks
    are extracted with the pressure index set. Same interface as ``DirectSolver``; counters
    ``factorizations`` (preconditioner set-ups), ``solves``, ``krylov_iterations`` (total)
    and ``last_iterations``.
    """

    def __init__(self, comm, W: fem.FunctionSpace, velocity_dofs: np.ndarray,
                 pressure_dofs: np.ndarray, mass_form, laplacian_form, laplacian_bcs=(),
                 prefix: str = "dpc_flow_", rtol: float = RTOL, max_it: int = MAX_IT):
        im = W.dofmap.index_map
        size_local = im.size_local * W.dofmap.index_map_bs
        offset = im.local_range[0] * W.dofmap.index_map_bs
        self.is_u = _owned_is(comm, velocity_dofs, size_local, offset)
        self.is_u.setBlockSize(2)   # (x, y) of a node are adjacent in W's numbering
        self.is_p = _owned_is(comm, pressure_dofs, size_local, offset)
        self.mass = _PressureBlock(mass_form, (), self.is_p)
        self.laplacian = _PressureBlock(laplacian_form, list(laplacian_bcs), self.is_p)
        self.schur_pc = _CahouetChabard(comm, prefix + "schur_laplacian_")

        self.ksp = ksp = PETSc.KSP().create(comm)
        ksp.setOptionsPrefix(prefix)
        ksp.setType("fgmres")
        ksp.setGMRESRestart(100)
        ksp.setTolerances(rtol=rtol, atol=0.0, max_it=max_it)
        ksp.setInitialGuessNonzero(True)
        pc = ksp.getPC()
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("u", self.is_u), ("p", self.is_p))
        pc.setFieldSplitType(PETSc.PC.CompositeType.SCHUR)
        pc.setFieldSplitSchurFactType(PETSc.PC.SchurFactType.UPPER)
        opts = PETSc.Options()
        defaults = DEFAULT_OPTIONS if compat.amg_type() == "hypre" else GAMG_OPTIONS
        for key, value in defaults.items():
            if not opts.hasName(prefix + key):
                opts[prefix + key] = value
        ksp.setFromOptions()
        self._python_pc_set = False
        self.factorizations = 0
        self.solves = 0
        self.krylov_iterations = 0
        self.fallbacks = 0   # step attempts Newton failed and Picard redid (models.stokes.newton)
        self.last_iterations = 0
        self.solve_iterations: list[int] = []
        #: set-up (operators, then the AMG hierarchies at the first solve) and solve time
        self.seconds = {"factorization": 0.0, "solve": 0.0}
        self._setup_due = False

    def set_operator(self, A: PETSc.Mat, refactor: bool = True) -> None:
        """Give a (re)assembled matrix: M_ν and L are reassembled from the current iterate
        and Δt, and the AMG hierarchies are rebuilt at the next solve (``refactor`` is
        accepted for the DirectSolver interface and ignored)."""
        t0 = time.perf_counter()
        M = self.mass.assemble()
        self.schur_pc.update(M, self.laplacian.assemble())
        pc = self.ksp.getPC()
        pc.setFieldSplitSchurPreType(PETSc.PC.SchurPreType.USER, M)
        self.ksp.setOperators(A)
        if not self._python_pc_set:   # the Schur sub-KSP exists after the first set-up
            self.ksp.setUp()
            schur_pc = pc.getFieldSplitSubKSP()[1].getPC()
            schur_pc.setType(PETSc.PC.Type.PYTHON)
            schur_pc.setPythonContext(self.schur_pc)
            self._python_pc_set = True
        self.factorizations += 1
        self._setup_due = True
        self.seconds["factorization"] += time.perf_counter() - t0

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        if self._setup_due:   # AMG hierarchies: part of the set-up time
            t0 = time.perf_counter()
            self._setup_due = False
            self.ksp.setUp()
            self.seconds["factorization"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        self.ksp.solve(b, x)
        self.seconds["solve"] += time.perf_counter() - t0
        its = self.ksp.getIterationNumber()
        self.solves += 1
        self.krylov_iterations += its
        self.last_iterations = its
        self.solve_iterations.append(its)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RuntimeError(f"Krylov solve failed after {its} iterations (PETSc reason "
                               f"{reason}, residual {self.ksp.getResidualNorm():.3e})")

    def destroy(self) -> None:
        self.ksp.destroy()
        for obj in (self.mass, self.laplacian, self.schur_pc, self.is_u, self.is_p):
            obj.destroy()


class _PressureBlock:
    """The (p, p) block of a bilinear form on W, reassembled in place."""

    def __init__(self, form, bcs, is_p: PETSc.IS):
        self.form, self.bcs, self.is_p = fem.form(form), bcs, is_p
        self._full = compat.create_matrix(self.form)
        self.block = None

    def assemble(self) -> PETSc.Mat:
        F = self._full
        F.zeroEntries()
        fem_petsc.assemble_matrix(F, self.form, bcs=self.bcs)
        F.assemble()
        self.block = F.createSubMatrix(self.is_p, self.is_p, submat=self.block)
        return self.block

    def destroy(self) -> None:
        self._full.destroy()
        if self.block is not None:
            self.block.destroy()


class _CahouetChabard:
    """Python PC on the Schur block: y = −(diag(M_ν)⁻¹ x + AMG(L) x)."""

    def __init__(self, comm, prefix: str):
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setType("preonly")
        amg = compat.amg_type()
        self.ksp.getPC().setType(amg)
        if amg == "hypre":
            self.ksp.getPC().setHYPREType("boomeramg")
        self.ksp.setFromOptions()
        self.inverse_diagonal = None
        self._work = None

    def update(self, M: PETSc.Mat, L: PETSc.Mat) -> None:
        self.ksp.setOperators(L)
        self.inverse_diagonal = M.getDiagonal(self.inverse_diagonal)
        self.inverse_diagonal.reciprocal()

    def setUp(self, pc) -> None:   # petsc4py's Python PC protocol
        pass

    def apply(self, pc, x: PETSc.Vec, y: PETSc.Vec) -> None:
        if self._work is None:
            self._work = x.duplicate()
        self.ksp.solve(x, self._work)
        y.pointwiseMult(self.inverse_diagonal, x)
        y.axpy(1.0, self._work)
        y.scale(-1.0)

    def destroy(self, pc=None) -> None:
        """Free the PETSc objects (also called by PETSc, with the PC, when the PC goes)."""
        self.ksp.destroy()
        for obj in (self.inverse_diagonal, self._work):
            if obj is not None:
                obj.destroy()
        self.inverse_diagonal = self._work = None


def _owned_is(comm, dofs: np.ndarray, size_local: int, offset: int) -> PETSc.IS:
    """Sorted index set of the owned entries of ``dofs`` (local W indices) in W's global
    numbering (PCFIELDSPLIT's Schur split needs sorted sets)."""
    owned = np.asarray(dofs, dtype=np.int64)
    owned = np.sort(owned[owned < size_local])
    return PETSc.IS().createGeneral((owned + offset).astype(PETSc.IntType), comm=comm)
