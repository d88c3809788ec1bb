"""Issue 50: the CPU of the volume fraction's advection per step, the geometric (PLIC) flux
against the compression, interleaved in one run (the machine is shared: ratios only).

    python studies/benchmarks/two_phase/interface_flux_cost.py [CELLS] [STEPS] [ROUNDS]

A 0.25 m square on the unit box of CELLS × CELLS squares (two triangles each), carried by a
solid rotation (one turn per second) for STEPS steps of 0.01 s; each ROUND runs every scheme
once in turn. Printed: the scheme, the sub-steps per step, the CPU per step and per sub-step
(``time.process_time``), the mixed area (0.01 < c < 0.99) over 2 H × the perimeter (1 m).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from dolfinx import fem
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # studies/ is not installed
from dpcollapse import compat  # noqa: E402
from dpcollapse.models.two_phase.fraction import VolumeFraction, owned_triangles  # noqa: E402
from dpcollapse.models.two_phase.overlap import rectangle_fraction  # noqa: E402

SCHEMES = {"compression C=1 normal": dict(compression=1.0),
           "geometric": dict(compression=0.0, interface_flux="geometric")}


def run(mesh, cells: int, steps: int, options: dict) -> tuple[float, float, float]:
    vf = VolumeFraction(mesh, 0.4, **options)
    u = fem.Function(compat.vector_space(mesh, 2))
    u.interpolate(lambda x: np.vstack([-2 * math.pi * (x[1] - 0.5), 2 * math.pi * (x[0] - 0.5)]))
    vf.bind(u)
    n = compat.num_owned_cells(mesh)
    tri = owned_triangles(mesh)
    vf.c.x.array[compat.cell_dofs(vf.S0)[:n, 0]] = rectangle_fraction(tri, (0.3, 0.15), (0.55, 0.4))
    vf.c.x.scatter_forward()
    substeps, start = 0, time.process_time()
    for _ in range(steps):
        substeps += vf.advance(0.01)
        vf.accept()
    cpu = time.process_time() - start
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    c = vf.c.x.array[compat.cell_dofs(vf.S0)[:n, 0]]
    mixed = area[(c > 0.01) & (c < 0.99)].sum() / (2.0 / cells)
    vf.destroy()
    return substeps / steps, cpu / steps, mixed


def main(argv) -> int:
    cells = int(argv[0]) if argv else 64
    steps = int(argv[1]) if len(argv) > 1 else 20
    rounds = int(argv[2]) if len(argv) > 2 else 3
    mesh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (cells, cells))
    for name, options in SCHEMES.items():      # compile the forms outside the timing
        run(mesh, cells, 1, options)
    for r in range(rounds):
        for name, options in SCHEMES.items():
            sub, cpu, mixed = run(mesh, cells, steps, options)
            print(f"round {r} {name}: {sub:.1f} sub-steps/step, {1e3 * cpu:.1f} ms CPU/step, "
                  f"{1e3 * cpu / sub:.2f} ms/sub-step, mixed area {mixed:.2f} × 2H·P", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
