"""CPU time of the parts of a two-phase run without a profiler (issue 51): ``time.process_time``
around about twenty functions of the loop, the flow step, the linear algebra and the adaptive
rebuild, printed at the end (count, CPU, share of the process's CPU). A nested part is counted
in each enclosing one (the LU in the step, the remap in the rebuild).

    python studies/benchmarks/two_phase/cpu_parts.py TAG run configs/column_eulerian_a6.26_adaptive.yaml \\
        --out R --set time.end_time=0.3 --quiet

(the arguments after TAG are ``dpcollapse``'s). cProfile times every Python call and so
overstates Python-heavy code (the remap's candidate search: 9.4 s under cProfile, 3.4 s
here to t = 0.3 s, benchmarks/2026-12-07-adaptive-column-speed.md); this wrapper costs
nothing measurable.
"""

import atexit
import sys
import time

from dpcollapse import cli, simulation
from dpcollapse.domain import adaptive_box
from dpcollapse.models.stokes import state
from dpcollapse.models.two_phase import adapter, flow, fraction, remap
from dpcollapse.solvers import assembly, linear

TIMES: dict[str, list] = {}

#: (owner, attribute, label): the parts timed, in the printed order
PARTS = (
    (adapter.TwoPhaseFactory, "start", "start"),
    (flow.TwoPhaseFlow, "solve_step", "step: flow + advection"),
    (linear.DirectSolver, "solve", "  LU + triangular solve"),
    (assembly.LinearSystem, "assemble_matrix", "  flow matrix assembly"),
    (fraction.VolumeFraction, "advance", "  advection of c"),
    (simulation.Simulation, "_remesh", "rebuild (all)"),
    (adaptive_box.AdaptiveBox, "remesh", "  size field + gmsh + mesh"),
    (adaptive_box.SizeField, "__call__", "    size field"),
    (adapter.TwoPhaseFactory, "rebuild", "  new discretization"),
    (flow, "remap_fields", "  remap c, c_prev"),
    (remap, "candidate_pairs", "    candidate pairs"),
    (remap, "pair_overlaps", "    overlaps"),
    (state.StokesState, "transfer", "  u, p interpolation"),
    (flow.TwoPhaseFlow, "snapshot", "  snapshot"),
    (adapter.TwoPhaseDiscretization, "measures", "measures"),
    (adaptive_box.AdaptiveBox, "needs_remesh", "remesh test"),
    (simulation.Simulation, "_output", "output"),
)


def _timed(function, label: str):
    def timed(*args, **kwargs):
        t0 = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            entry = TIMES.setdefault(label, [0, 0.0])
            entry[0] += 1
            entry[1] += time.process_time() - t0
    return timed


def report(tag: str) -> None:
    total = time.process_time()
    print(f"{tag}: total CPU {total:.2f} s", file=sys.stderr)
    for _, _, label in PARTS:
        n, t = TIMES.get(label, (0, 0.0))
        print(f"{tag}: {label:30s} {n:5d} {t:8.2f} s {100 * t / total:5.1f} %", file=sys.stderr)


def main(argv: list[str]) -> None:
    tag, sys.argv = argv[0], ["dpcollapse", *argv[1:]]
    for owner, name, label in PARTS:
        setattr(owner, name, _timed(getattr(owner, name), label))
    atexit.register(report, tag)
    cli.entry()


if __name__ == "__main__":
    main(sys.argv[1:])
