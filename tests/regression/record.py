"""Regression cases: short runs of every model, scene and method, and the full rigid collapse.

Each case is a config of ``configs/`` with ``--set`` overrides; :func:`run_case` runs it
with :class:`dpcollapse.simulation.Simulation` and returns a few scalars of the end state
(number of steps and remeshes, front, maximum height, kinetic energy, max speed, total
fixed-point iterations). ``spread.py`` runs these cases under several floating-point
environments and writes ``reference.json`` (the centre of each measured range and its
tolerance); ``test_regression.py`` compares the current code with it.

This file imports nothing from ``tests`` so that it can run against an older checkout::

    PYTHONPATH=/path/to/old/checkout python tests/regression/record.py --out values.json [CASE ...]

(the configs are taken from the checkout that provides ``dpcollapse``).
"""

from __future__ import annotations

import os

# One BLAS/OpenMP thread, as the command line and the test suite run: threaded BLAS inside
# MUMPS changes the round-off, and on DOLFINx 0.11 that moved the full rigid run by 3 remeshes.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json
import subprocess
import sys
import tempfile
from pathlib import Path

#: name -> (config file in configs/, overrides). Short runs: a few seconds each.
CASES: dict[str, tuple[str, list[str]]] = {
    # rigid-bed trapezoid at 2 cm through its first remesh (≈ t = 0.096 s)
    "rigid_short": ("rigid.yaml", ["geometry.mesh_size=0.02", "time.end_time=0.12",
                                   "time.output_every=30", "time.checkpoint_every=40"]),
    # periodic plug layer (Drucker–Prager, fixed domain, no-slip bed), 0.1 s of the stop
    "plug_short": ("plug.yaml", ["geometry.mesh_size=0.01", "time.end_time=0.1",
                                 "time.output_every=1000", "time.checkpoint_every=1000"]),
    # periodic μ(I) layer on a slope (the Bagnold validation's scene), 5 steps from rest
    "bagnold_short": ("bagnold.yaml", ["geometry.mesh_size=0.004", "time.end_time=0.1",
                                       "time.output_every=1000", "time.checkpoint_every=1000"]),
    # augmented Lagrangian collapse at 4 cm through a remesh (BDF1 at a fixed 1 ms: it
    # refuses rigid.yaml's bdf2 and error control; tests.helpers.RIGID_BDF1)
    "al_short": ("rigid.yaml", ["numerics.method=augmented_lagrangian", "time.scheme=bdf1",
                                "time.tolerance=null", "time.dt_max=1.5e-3", "geometry.mesh_size=0.04",
                                "time.end_time=0.05", "numerics.remesh_min_angle=44.5",
                                "time.output_every=10", "time.checkpoint_every=10"]),
    # μ(I) collapse (regularized), 3 cm, a few steps
    "mu_i_collapse_short": ("slope22_mui.yaml", ["geometry.mesh_size=0.03", "time.end_time=0.03",
                                                 "time.output_every=1000",
                                                 "time.checkpoint_every=1000"]),
    # the two-phase model (fixed box, volume fraction c): the a = 0.5 column on 1 cm cells of
    # the 0.3 m x 0.1 m box, 0.1 s of its collapse (the front at its fastest)
    "two_phase_short": ("column_eulerian_a0.5.yaml", ["geometry.mesh_size=0.01", "time.end_time=0.1",
                                                      "time.output_every=1000",
                                                      "time.checkpoint_every=1000"]),
    # the depth-averaged Savage–Hutter model: the column of configs/column_sh.yaml on 200
    # cells (second order), 0.3 s of its spreading
    "savage_hutter_short": ("column_sh.yaml", ["model.n_cells=200", "time.end_time=0.3",
                                               "time.output_every=1000",
                                               "time.checkpoint_every=1000"]),
}
#: The full run of configs/rigid.yaml to rest (BDF2, time.tolerance 1e-4: ~35 s serial).
FULL = {"rigid_full": ("rigid.yaml", [])}

#: Scalars compared; steps, remeshes and flow_solves are integers (compared exactly).
KEYS = ("steps", "remeshes", "flow_solves", "t", "front", "max_height", "kinetic_energy",
        "max_speed")


def configs_dir() -> Path:
    import dpcollapse

    return Path(dpcollapse.__file__).resolve().parent.parent / "configs"


def run_case(name: str, run_dir: Path, comm=None) -> dict:
    """Run case ``name`` in ``run_dir``; the scalars of :data:`KEYS` (all ranks get them)."""
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.simulation import Simulation

    comm = comm or MPI.COMM_WORLD
    config, overrides = {**CASES, **FULL}[name]
    cfg = load_config(configs_dir() / config, overrides)
    sim = Simulation(cfg, run_dir, quiet=True, comm=comm)
    summary = sim.run()
    m = sim.disc.measures()
    out = {k: summary[k] for k in ("steps", "remeshes", "flow_solves", "t", "front", "max_height",
                                    "kinetic_energy")}
    out["max_speed"] = m["max_speed"]
    out["status"] = summary["status"]
    return out


def _commit() -> str:
    import dpcollapse

    root = Path(dpcollapse.__file__).resolve().parent.parent
    try:
        return subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help=f"default: all of {list(CASES) + list(FULL)}")
    ap.add_argument("--out", type=Path, required=True, help="JSON file (updated in place)")
    args = ap.parse_args(argv)
    names = args.cases or list(CASES) + list(FULL)
    data = json.loads(args.out.read_text()) if args.out.exists() else {}
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            values = run_case(name, Path(tmp))
        values["commit"] = _commit()
        data[name] = values
        print(name, values, flush=True)
        args.out.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
