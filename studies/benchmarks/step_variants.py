"""Variants of the error-controlled step on the rigid collapse (issue 25): experiments, not
options of the solver.

    python benchmarks/step_variants.py VARIANT RUN_DIR [--set SECTION.KEY=VALUE ...]
    python benchmarks/time_order.py --reference-run REF --runs RUN_DIR ... --csv … --png …

runs ``configs/rigid.yaml`` (BDF2, ``time.tolerance`` 3e-4 m/s in the max norm) with one
change to the step control, made here by replacing one method for this process only:

    base           the code as it is
    elementary     Δt_{n+1} = Δt_n · SAFETY (tol/e_n)^{1/k}: the elementary controller instead of
                   the PI one (whose (e_{n−1}/tol)^{0.4/k} slows the growth while e ≪ tol)
    displacement   the estimate is Δt · max|e_u| [m] (the nodes' displacement error of the step,
                   the quantity the front history integrates) with k = 4; ``--set
                   time.tolerance=…`` is then in metres
    first-estimate the first estimate after a remesh or a landing (three steps without one) never
                   rejects the step, it only sets the next one (the history it extrapolates was
                   made without error control; a retry cannot reduce that part)
    speed-floor    the fixed point's absolute floor follows the flow: atol = min(0.3 tol,
                   0.03 max(time.rest_speed, max|uⁿ|/10)) instead of min(0.3 tol, 0.03 rest_speed)
    hybrid         the PI controller while e_n ≥ tol/2, the elementary one below (the PI's
                   (e_{n−1}/tol)^{0.4/k} holds the growth at ~1.13 per step while e_n ≈ e_{n−1} ≪ tol,
                   e.g. for ~40 steps after a landing)

The measured numbers: ``docs/benchmarks/2026-12-04-rigid-step-variants.md`` (``hybrid``:
``docs/benchmarks/2026-12-05-rigid-iterate-cost.md``).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
VARIANTS = ("base", "elementary", "displacement", "first-estimate", "speed-floor", "hybrid")


def _elementary_step(sc, controller, dt, error):
    """Δt · SAFETY (tol/e)^{1/k}, bounded as the PI step (``error`` not None)."""
    error = max(error, 1e-12 * controller.tolerance)
    controller.previous_error = error
    factor = sc.SAFETY * (controller.tolerance / error) ** (1.0 / sc.ORDER)
    return dt * min(sc.GROW, max(sc.SHRINK, factor))


def _elementary(sc) -> None:
    def next_step(self, dt, error):
        return dt if error is None else _elementary_step(sc, self, dt, error)
    sc.StepController.next_step = next_step


def _hybrid(sc) -> None:
    pi = sc.StepController.next_step

    def next_step(self, dt, error):
        if error is None or error >= 0.5 * self.tolerance:
            return pi(self, dt, error)
        return _elementary_step(sc, self, dt, error)
    sc.StepController.next_step = next_step


def _displacement(sc, state) -> None:
    sc.ORDER = 4
    original = state.StokesState.local_error

    def local_error(self):
        error = original(self)
        return None if error is None else error * self._step_dt
    state.StokesState.local_error = local_error


def _first_estimate(sc, state) -> None:
    first = {"now": False}
    original = state.StokesState.local_error

    def local_error(self):
        error = original(self)
        first["now"] = error is not None and self.history.solved <= 3
        return error
    state.StokesState.local_error = local_error
    accept = sc.StepController.accept
    sc.StepController.accept = lambda self, error: True if first["now"] else accept(self, error)


def _speed_floor(regularized, cfg) -> None:
    from mpi4py import MPI

    tol, rest = cfg.time.tolerance, cfg.time.rest_speed
    original = regularized.RegularizedFlow.solve_step

    def solve_step(self, dt):
        u = self.velocity_values(self.iterate)   # uⁿ: the iterate starts at the accepted state
        speed = self.comm.allreduce(float(np.max(np.abs(u))) if len(u) else 0.0, op=MPI.MAX)
        atol = min(0.3 * tol, 0.03 * max(rest, speed / 10.0))
        self.settings = dataclasses.replace(self.settings, atol=atol)
        return original(self, dt)
    regularized.RegularizedFlow.solve_step = solve_step


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("variant", choices=VARIANTS)
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args(argv)

    from dpcollapse import simulation
    from dpcollapse.config.files import load_config
    from dpcollapse.models.stokes import regularized, state
    from dpcollapse.solvers import step_control as sc

    cfg = load_config(ROOT / "configs" / "rigid.yaml", args.overrides)
    if args.variant == "elementary":
        _elementary(sc)
    elif args.variant == "displacement":
        _displacement(sc, state)
    elif args.variant == "first-estimate":
        _first_estimate(sc, state)
    elif args.variant == "hybrid":
        _hybrid(sc)
    elif args.variant == "speed-floor":
        _speed_floor(regularized, cfg)
    simulation.run_simulation(cfg, args.run_dir, quiet=True)


if __name__ == "__main__":
    main()
