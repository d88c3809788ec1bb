"""What one Picard iterate of the rigid collapse costs, and what a stale factorization buys
(issue 25): a measurement, not an option of the solver.

    python benchmarks/flow_iterate_cost.py [--at N] [--repeat R]

runs ``configs/rigid.yaml`` up to the N-th flow step attempt (default 300, t ≈ 0.2 s: the
spreading, the nose landed), and there, on that mesh and state, prints

1. the matrix assembly as the solver does it (all terms, PETSc AIJ) and each bilinear term alone
   (their sum against the whole shows the per-assembly cost that is not the kernels);
2. the factorization of the Picard matrix: MUMPS LDLᵀ (the solver's) with the orderings AMD,
   PORD, METIS and MUMPS's automatic choice, and LU; the flops of the LDLᵀ (MUMPS RINFOG(3))
   and the rate they run at;
3. a stale factorization used for the next iterate: A₀ = A(uⁿ) factorized, the Picard iterate
   u¹ = A₀⁻¹b₀ taken, A₁ = A(u¹) assembled; then A₁x = b₁ solved by FGMRES preconditioned by
   A₀'s factors to a relative residual 1e-3, 1e-6, 1e-9, and the velocity of each solution
   compared with the exact one (A₁'s own factors): iterations, milliseconds, error
   ‖x − x_exact‖/‖x_exact‖ on the velocity dofs.

The numbers: ``docs/benchmarks/2026-12-05-rigid-iterate-cost.md``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _timed(fn, repeat: int) -> float:
    """Median wall time of ``fn()`` over ``repeat`` calls after one warm-up [ms]."""
    fn()
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(samples)


def _factor(A, kind: str, ordering: int | None, prefix: str):
    """The solver's ``DirectSolver`` (MUMPS LDLᵀ for ``cholesky``, else LU) on ``A``, factorized
    once; ``ordering``: MUMPS ICNTL(7) (None: its automatic choice)."""
    from petsc4py import PETSc

    from dpcollapse.solvers.linear import DirectSolver

    if ordering is not None:   # read by the solver's setFromOptions
        PETSc.Options()[f"{prefix}mat_mumps_icntl_7"] = ordering
    solver = DirectSolver(A.getComm(), "mumps", prefix=prefix, symmetric=kind == "cholesky")
    solver.set_operator(A)
    solver.ksp.setUp()
    return solver.ksp


def measure(flow, repeat: int) -> None:
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    system = flow.system
    size = system.A.getSize()[0]
    cells = flow.mesh.topology.index_map(flow.mesh.topology.dim).size_local
    print(f"mesh: {cells} cells, {size} flow dofs, velocity scale max|u| = "
          f"{np.max(np.abs(flow.velocity_values(flow.iterate))):.3f} m/s")

    print("\n1. assembly [ms]")
    print(f"  {'all terms, as the solver':34s} {_timed(system.assemble_matrix, repeat):7.2f}")
    total = 0.0
    for name, term in flow.terms.items():
        form = fem.form(term)
        A = fem_petsc.assemble_matrix(form)
        A.assemble()

        def one(A=A, form=form):
            A.zeroEntries()
            fem_petsc.assemble_matrix(A, form)
            A.assemble()
        ms = _timed(one, repeat)
        total += ms
        print(f"  {name:34s} {ms:7.2f}")
        A.destroy()
    print(f"  {'sum of the terms alone':34s} {total:7.2f}")
    print(f"  {'right-hand side':34s} {_timed(system.assemble_vector, repeat):7.2f}")

    A0 = system.assemble_matrix().copy()
    b0 = system.assemble_vector().copy()
    print("\n2. factorization of the Picard matrix [ms]")
    variants = [("LDLt, automatic ordering (the solver's)", "cholesky", None),
                ("LDLt, AMD", "cholesky", 0), ("LDLt, PORD", "cholesky", 4),
                ("LDLt, METIS", "cholesky", 5), ("LU, automatic ordering", "lu", None)]
    for i, (label, kind, ordering) in enumerate(variants):
        B = A0.copy()
        ksp = _factor(B, kind, ordering, f"bench{i}_")

        def refactor(B=B, ksp=ksp):
            A0.copy(B, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)  # new state
            ksp.setOperators(B)
            ksp.setUp()
        ms = _timed(refactor, repeat)
        F = ksp.getPC().getFactorMatrix()
        flops = F.getMumpsRinfog(3)
        print(f"  {label:40s} {ms:7.2f}   {flops / 1e6:6.1f} MFlop  "
              f"{flops / ms / 1e6:5.2f} GFlop/s  factor entries {F.getMumpsInfog(9)}")
        ksp.destroy()
        B.destroy()

    print("\n3. the next iterate's system with the stale factors of A(uⁿ)")
    ksp0 = _factor(A0, "cholesky", None, "stale0_")
    x1 = A0.createVecRight()
    ksp0.solve(b0, x1)
    flow.iterate.x.array[:] = x1.array_r       # the Picard iterate u¹ (serial)
    flow.iterate.x.scatter_forward()
    A1 = system.assemble_matrix().copy()
    b1 = system.assemble_vector().copy()
    diff = A1.copy()
    diff.axpy(-1.0, A0)
    print(f"  ‖A₁ − A₀‖/‖A₀‖ = {diff.norm() / A0.norm():.2e}")
    exact = A1.createVecRight()
    ksp1 = _factor(A1.copy(), "cholesky", None, "stale1_")
    ksp1.solve(b1, exact)
    velocity = np.asarray(flow.velocity_dofs)
    x_exact = exact.array_r[velocity]
    print(f"  exact (A₁'s own factors): {_timed(lambda: ksp1.solve(b1, exact), repeat):.2f} ms "
          "for the back-substitution")
    for rtol in (1e-3, 1e-6, 1e-9):
        ksp = PETSc.KSP().create(A1.getComm())
        ksp.setType("fgmres")
        ksp.setGMRESRestart(100)
        ksp.setTolerances(rtol=rtol, atol=0.0, max_it=200)
        ksp.setOperators(A1, A0)
        ksp.setPC(ksp0.getPC())
        x = A1.createVecRight()
        t0 = time.perf_counter()
        ksp.solve(b1, x)
        ms = 1e3 * (time.perf_counter() - t0)
        error = np.linalg.norm(x.array_r[velocity] - x_exact) / np.linalg.norm(x_exact)
        print(f"  FGMRES to rtol {rtol:g}: {ksp.getIterationNumber():3d} iterations {ms:6.2f} ms, "
              f"velocity error {error:.1e} (reason {ksp.getConvergedReason()})")
        ksp.destroy()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--at", type=int, default=300, help="flow step attempt to measure at")
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args(argv)

    from dpcollapse import simulation
    from dpcollapse.config.files import load_config
    from dpcollapse.models.stokes import regularized

    original = regularized.RegularizedFlow.solve_step
    calls = {"n": 0}

    def solve_step(self, dt):
        calls["n"] += 1
        if calls["n"] == args.at:
            if self.comm.size > 1:
                sys.exit("flow_iterate_cost.py: serial only")
            self.set_step(dt)
            self.update_surface_tension()
            measure(self, args.repeat)
            raise SystemExit(0)
        return original(self, dt)
    regularized.RegularizedFlow.solve_step = solve_step

    cfg = load_config(ROOT / "configs" / "rigid.yaml", [])
    with tempfile.TemporaryDirectory() as out:
        simulation.run_simulation(cfg, Path(out) / "run", quiet=True)


if __name__ == "__main__":
    main()
