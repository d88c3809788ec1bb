"""Newton's method for F(U) = 0 with PETSc SNES, the residual and Jacobian assembled by DOLFINx.

``SnesNewton`` drives a system whose bilinear form is the Jacobian J and whose linear form
is −F (a ``solvers.assembly.LinearSystem`` or, on a periodic layer, a
``solvers.periodic.PeriodicLinearSystem``: the iteration then runs on the reduced vector
and ``system.load`` back-substitutes the slave dofs before every assembly). Each Newton
iteration solves J δ = −F by LU (``preonly``, MUMPS or SuperLU_dist) — one factorization
per Jacobian — and takes x ← x + λ δ with λ from the SNES line search ``line_search``
(basic: λ = 1; bt: backtracking on ½‖F‖²; l2, cp, nleqerr: PETSc's secant/critical-point
and error-oriented variants). The stopping test is the caller's ``converged(iteration)``
(called after each update with the iterate loaded into the forms' Function; ``direction``
holds the full, undamped Newton step of that iteration, recorded before the line search).

Counters kept for benchmarks (as ``solvers.linear.DirectSolver``): ``factorizations``
(Jacobian evaluations), ``solves``, ``krylov_iterations`` (0), ``seconds``
{"factorization": Jacobian assembly + LU set-up is not separable inside SNES, so the whole
SNES time is booked under "solve"}, and ``history``: (iteration, ‖F‖₂) of the last solve.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from petsc4py import PETSc

#: SNES line searches that ``numerics.newton_line_search`` accepts.
LINE_SEARCHES = ("bt", "basic", "l2", "cp", "nleqerr")


class SnesNewton:
    """PETSc SNES (newtonls) on a J/−F system, LU for every Newton step."""

    def __init__(self, comm, system, state, converged: Callable[[int], bool],
                 package: str = "mumps", line_search: str = "bt", max_iterations: int = 50,
                 prefix: str = "dpc_newton_"):
        """system: J/−F system with ``assemble_matrix``, ``assemble_vector``, ``load``,
        ``store``, ``A`` and ``b``; state: the Function U the forms depend on."""
        if line_search not in LINE_SEARCHES:
            raise ValueError(f"line search must be one of {LINE_SEARCHES}, got {line_search!r}")
        self.system = system
        self.state = state
        self._converged = converged
        self.x = system.b.duplicate()
        self._f = system.b.duplicate()
        snes = PETSc.SNES().create(comm)
        snes.setOptionsPrefix(prefix)
        snes.setType("newtonls")
        snes.setFunction(self._residual, self._f)
        snes.setJacobian(self._jacobian, system.A)
        snes.setConvergenceTest(self._test)
        snes.setLineSearchPreCheck(self._precheck)
        snes.setTolerances(max_it=max_iterations)
        snes.setErrorIfNotConverged(False)
        ksp = snes.getKSP()
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType(package)
        opts = PETSc.Options()
        # petsc4py 3.18 has no SNESLineSearch object: the type goes through the options
        opts[f"{prefix}snes_linesearch_type"] = line_search
        if package == "mumps":
            opts[f"{prefix}mat_mumps_icntl_14"] = 200  # workspace headroom for pivoting
            opts[f"{prefix}mat_mumps_icntl_24"] = 0
        snes.setFromOptions()
        self.snes = snes
        self.factorizations = 0
        self.solves = 0
        self.krylov_iterations = 0
        self.seconds = {"factorization": 0.0, "solve": 0.0}
        self.history: list[tuple[int, float]] = []
        self.direction = None   # local values of the last full Newton step δ (before damping)

    # ------------------------------------------------------------------ callbacks
    def _residual(self, snes, x, f) -> None:
        self.system.load(x, self.state)
        b = self.system.assemble_vector()   # −F, zero on Dirichlet rows
        b.copy(f)
        f.scale(-1.0)

    def _jacobian(self, snes, x, J, P) -> None:
        self.system.load(x, self.state)
        self.system.assemble_matrix()
        self.factorizations += 1

    def _precheck(self, x, y, *args):
        self.direction = y.array_r.copy()
        return False   # y unchanged

    def _test(self, snes, iteration, norms) -> int:
        _, _, fnorm = norms
        self.history.append((int(iteration), float(fnorm)))
        if fnorm != fnorm:   # NaN
            return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
        if iteration == 0:
            return PETSc.SNES.ConvergedReason.ITERATING
        self.system.load(snes.getSolution(), self.state)
        if self._converged(int(iteration)):
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
        return PETSc.SNES.ConvergedReason.ITERATING

    # ------------------------------------------------------------------ solve
    def solve(self) -> tuple[int, int]:
        """Newton from the current ``state``; ``state`` holds the last iterate afterwards.
        Returns (SNES converged reason, iterations)."""
        self.history = []
        self.system.store(self.state, self.x)
        t0 = time.perf_counter()
        self.snes.solve(None, self.x)
        self.seconds["solve"] += time.perf_counter() - t0
        iterations = self.snes.getIterationNumber()
        self.solves += iterations
        self.system.load(self.x, self.state)
        return int(self.snes.getConvergedReason()), int(iterations)

    def destroy(self) -> None:
        self.snes.destroy()
        self.x.destroy()
        self._f.destroy()


def reason_name(reason: int) -> str:
    """The SNES converged-reason constant's name, e.g. DIVERGED_LINE_SEARCH."""
    for name, value in vars(PETSc.SNES.ConvergedReason).items():
        if not name.startswith("_") and value == reason:
            return name
    return str(reason)
