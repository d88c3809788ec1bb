"""Direct sparse solve with PETSc (MUMPS or SuperLU_dist LU; MUMPS LDLᵀ for symmetric matrices;
Cholesky for symmetric positive definite ones).

The KSP is kept across solves: when the matrix keeps its nonzero pattern PETSc redoes
only the numeric factorization, and the symbolic analysis is reused. A symmetric matrix
(``symmetric=True``: the caller guarantees it, e.g. the Picard system with the convection
lagged) is factorized by MUMPS as LDLᵀ (PETSc's Cholesky PC; MUMPS
SYM = 2, symmetric indefinite, which the saddle point needs): half the flops and storage of
LU (measured on the rigid collapse's 9428-dof Taylor–Hood system: 11.0 against 20.0 ms).
A symmetric positive definite matrix (``positive_definite=True``, e.g. the mesh velocity's)
is factorized by Cholesky: PETSc's own in serial (nested dissection), MUMPS's (SYM = 1)
under MPI.
"""

from __future__ import annotations

import math
import time

from petsc4py import PETSc


class NonFiniteSystem(RuntimeError):
    """A matrix or right-hand side with a NaN or Inf entry, refused before it is factorized
    (MUMPS's symbolic analysis of such a matrix was seen never to return: issue 47). A
    RuntimeError, as a failed factorization is: the caller's step fails and is retried."""


def require_finite(kind: str, norm: float) -> None:
    """Raise :class:`NonFiniteSystem` unless ``norm`` (a Frobenius or 2-norm, collective:
    every rank sees the same value) is finite."""
    if not math.isfinite(norm):
        raise NonFiniteSystem(f"non-finite {kind} (norm {norm}): refused before the solve")


class DirectSolver:
    """LU (or, for a symmetric matrix with MUMPS, LDLᵀ) factorization of a PETSc matrix,
    reused across solves.

    With ``krylov=True`` the KSP is GMRES preconditioned by the LU factors, so that
    ``set_operator(A, refactor=False)`` keeps the old (stale) factorization as the
    preconditioner of the new matrix instead of factorizing again.

    Counts kept for benchmarks: ``factorizations``, ``solves``, ``krylov_iterations``,
    ``solve_iterations`` (per solve) and ``seconds`` {"factorization", "solve"} (the
    factorization is done by an explicit KSP set-up at the first solve after it is due).
    """

    def __init__(self, comm, package: str = "mumps", prefix: str = "dpc_", krylov: bool = False,
                 rtol: float = 1e-10, symmetric: bool = False, positive_definite: bool = False):
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(prefix)
        self.krylov = krylov
        if krylov:
            self.ksp.setType("gmres")
            self.ksp.setTolerances(rtol=rtol, atol=0.0, max_it=30)
            self.ksp.setGMRESRestart(30)
        else:
            self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        self.positive_definite = positive_definite
        if positive_definite and comm.size == 1:
            # PETSc's own sparse Cholesky, nested-dissection ordering: no external package's
            # set-up per factorization (measured on the ~2000-dof mesh velocity: 5.4 against
            # 9.4 ms per motion with MUMPS LU)
            package = "petsc"
            self.symmetric = True
            pc.setType("cholesky")
            pc.setFactorSolverType("petsc")
            pc.setFactorOrdering("nd")
        else:
            # LDLᵀ only with MUMPS (SuperLU_dist has no symmetric factorization)
            self.symmetric = (symmetric or positive_definite) and package == "mumps"
            pc.setType("cholesky" if self.symmetric else "lu")
            pc.setFactorSolverType(package)
        if package == "mumps":
            opts = PETSc.Options()
            opts[f"{prefix}mat_mumps_icntl_14"] = 200  # workspace headroom for pivoting
            opts[f"{prefix}mat_mumps_icntl_24"] = 0
        self.ksp.setFromOptions()
        self.factorizations = 0
        self.krylov_iterations = 0   # GMRES iterations in Krylov mode (0 with preonly)
        self.fallbacks = 0           # step attempts Newton failed and Picard redid (models.stokes.newton)
        self.solves = 0
        self.solve_iterations: list[int] = []
        self.seconds = {"factorization": 0.0, "solve": 0.0}
        self._setup_due = False
        self._operator = None

    def set_operator(self, A: PETSc.Mat, refactor: bool = True) -> None:
        """Give a (re)assembled matrix; the next solve refactorizes it unless ``refactor``
        is False (Krylov mode only: the old factors precondition the new matrix)."""
        reuse = self.krylov and not refactor
        self.ksp.getPC().setReusePreconditioner(reuse)
        if self.symmetric:   # the factorization takes one triangle; the flag says the caller means it
            A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
            if self.positive_definite:
                A.setOption(PETSc.Mat.Option.SPD, True)   # MUMPS: SYM = 1, no pivoting
        self.ksp.setOperators(A)
        self._operator = A
        if not reuse:
            self.factorizations += 1
            self._setup_due = True

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x = A⁻¹ b. A matrix (at its factorization) or a b with a NaN/Inf entry raises
        :class:`NonFiniteSystem` before MUMPS sees it."""
        require_finite("right-hand side", b.norm())
        if self._setup_due:   # the LU factorization, timed on its own
            require_finite("matrix", self._operator.norm(PETSc.NormType.FROBENIUS))
            t0 = time.perf_counter()
            self._setup_due = False
            self.ksp.setUp()
            self.seconds["factorization"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        self.ksp.solve(b, x)
        self.seconds["solve"] += time.perf_counter() - t0
        self.solves += 1
        its = self.ksp.getIterationNumber() if self.krylov else 0
        self.krylov_iterations += its
        self.solve_iterations.append(its)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RuntimeError(f"linear solve failed (PETSc reason {reason})")

    def destroy(self) -> None:
        self.ksp.destroy()
