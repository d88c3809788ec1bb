"""The cell estimate that ``dpcollapse check`` refuses sizes by (``config.sizes``), against
the cells the meshers make (issue 47): a measurement, not an option.

    python benchmarks/mesh_size_estimate.py [--adaptive]

For each config and its overrides, the first mesh is built serially (gmsh; with
``--adaptive`` also the adaptive two-phase box, whose start meshes it three times: about 40 s)
and its cells counted; printed: the cells made, the estimate, their ratio, the seconds.

The numbers: ``docs/benchmarks/2026-12-07-sizes.md``.
"""

from __future__ import annotations

import argparse
import time

from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config, with_overrides
from dpcollapse.config.sizes import first_mesh

#: (config, overrides): the moving mesh (with its free surface's cells), the silo and the
#: hopper (with their orifice's cells), a wide silo
MESHED = [
    ("rigid", []), ("rigid", ["geometry.surface_mesh_size=0.002"]),
    ("rigid", ["geometry.surface_mesh_size=0.0005"]), ("rigid", ["geometry.mesh_size=0.003"]),
    ("column_a1.42", []), ("column_a1.42", ["geometry.surface_mesh_size=0.001"]),
    ("erodible", []), ("bagnold", []),
    ("silo", []), ("silo", ["geometry.orifice_mesh_size=5e-4"]),
    ("silo", ["geometry.orifice_mesh_size=1e-4"]), ("silo", ["geometry.orifice_mesh_size=2e-5"]),
    ("silo", ["geometry.mesh_size=0.002"]), ("hopper", []),
    ("hopper", ["geometry.orifice_mesh_size=1e-4"]),
    ("silo", ["geometry.width=2.0", "geometry.orifice_mesh_size=1e-3", "geometry.mesh_size=0.02"]),
]
#: the adaptive two-phase box at L0/32 (the config's), L0/16 and L0/64
ADAPTIVE = [("column_eulerian_a6.26_adaptive", []),
            ("column_eulerian_a6.26_adaptive", ["model.min_cell=0.00625"]),
            ("column_eulerian_a6.26_adaptive", ["model.min_cell=0.0015625"])]


def _config(name: str, overrides: list[str]):
    cfg = load_config(f"configs/{name}.yaml")
    return with_overrides(cfg, overrides) if overrides else cfg


def made(name: str, overrides: list[str]) -> int:
    """Cells of the first mesh, as a run makes it."""
    cfg = _config(name, overrides)
    if cfg.model.name == "two_phase" and cfg.model.min_cell is not None:
        from dpcollapse.models.two_phase.adapter import TwoPhaseFactory

        return compat.num_owned_cells(TwoPhaseFactory(cfg).start(MPI.COMM_SELF).mesh)
    from dpcollapse.scenes.registry import build_mesh

    return compat.num_owned_cells(build_mesh(cfg, MPI.COMM_SELF).mesh)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--adaptive", action="store_true", help="also the adaptive box")
    args = parser.parse_args()
    print("| config | overrides | cells made | estimate | estimate / made | s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, overrides in MESHED + (ADAPTIVE if args.adaptive else []):
        t0 = time.perf_counter()
        n = made(name, overrides)
        seconds = time.perf_counter() - t0
        estimate = first_mesh(_config(name, overrides)).cells
        print(f"| {name} | {' '.join(overrides) or '—'} | {n} | {estimate:.0f} | "
              f"{estimate / n:.2f} | {seconds:.1f} |", flush=True)


if __name__ == "__main__":
    main()
