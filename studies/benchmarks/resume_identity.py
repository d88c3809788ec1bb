"""Resume identity (issue 47): each case runs whole, and again stopped after step k and
resumed (``--resume``); per quantity (Δt, max speed, front, kinetic energy) the relative
difference at the first resumed step and the largest over the resumed steps, and the final
checkpoints' fields (by node; "nodes differ" on a moving mesh, whose nodes move by
round-off). Report: docs/benchmarks/2026-12-07-resume-and-regression.md.

    python benchmarks/resume_identity.py CASE ...                       # this checkout
    CODE=/path/to/old PYTHONPATH=/path/to/old python benchmarks/resume_identity.py CASE ...
"""

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, os.environ.get("CODE", str(Path(__file__).resolve().parents[2])))
from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import RIGID_BDF1, simulation

R = ["geometry.mesh_size=0.03", "time.output_every=1000", "time.checkpoint_every=1000"]
TP = ["geometry.mesh_size=0.01", "time.output_every=1000", "time.checkpoint_every=1000"]
TPA = [
    "model.box_height=0.06",
    "time.dt=2e-3",
    "time.output_every=1000",
    "time.checkpoint_every=1000",
    "model.min_cell=0.01",
    "model.max_cell=0.04",
]
SH = ["model.n_cells=200", "model.order=1", "time.output_every=1000", "time.checkpoint_every=1000"]
CASES = {
    "bdf1": ("rigid.yaml", R + RIGID_BDF1 + ["time.end_time=0.03"], 10),
    "bdf1_extrap": ("rigid.yaml", R + RIGID_BDF1 + ["time.end_time=0.03", "numerics.extrapolate=true"], 10),
    "bdf1_adaptive": ("rigid.yaml", R + RIGID_BDF1 + ["time.end_time=0.05", "time.adaptive=true"], 10),
    "bdf2_fixed": ("rigid.yaml", R + ["time.scheme=bdf2", "time.tolerance=null", "time.end_time=0.03"], 10),
    "bdf2_tol": ("rigid.yaml", R + ["time.end_time=0.1"], 10),
    "newton": ("rigid.yaml", R + RIGID_BDF1 + ["time.end_time=0.02", "numerics.nonlinear_solver=newton"], 8),
    "al": ("rigid.yaml", R + RIGID_BDF1 + ["time.end_time=0.02", "numerics.method=augmented_lagrangian"], 8),
    "tp_extrap": ("column_eulerian_a0.5.yaml", TP + ["time.end_time=0.06", "numerics.extrapolate=true"], 6),
    "tp": ("column_eulerian_a0.5.yaml", TP + ["time.end_time=0.06"], 6),
    "tpa_extrap": (
        "column_eulerian_a0.5.yaml",
        TPA + ["time.end_time=0.05", "numerics.extrapolate=true", "numerics.fixed_iterations=1"],
        10,
    ),
    "tpa_a626": (
        "column_eulerian_a6.26_adaptive.yaml",
        [
            "time.end_time=0.03",
            "time.output_every=1000",
            "time.checkpoint_every=1000",
            "model.min_cell=0.0125",
            "model.max_cell=0.05",
        ],
        6,
    ),
    "a626": (
        "column_eulerian_a6.26_adaptive.yaml",
        ["time.end_time=0.04", "time.output_every=1000", "time.checkpoint_every=1000"],
        10,
    ),
    "a05_extrap": (
        "column_eulerian_a0.5.yaml",
        [
            "time.end_time=0.1",
            "time.output_every=1000",
            "time.checkpoint_every=1000",
            "numerics.extrapolate=true",
        ],
        10,
    ),
    "a626_long": (
        "column_eulerian_a6.26_adaptive.yaml",
        ["time.end_time=0.1", "time.output_every=1000", "time.checkpoint_every=1000"],
        40,
    ),
    "sh": ("column_sh.yaml", SH + ["time.end_time=0.1"], 20),
}


def run(name, tmp):
    config, over, k = CASES[name]
    comm = MPI.COMM_SELF
    t0 = time.time()
    full = simulation(config, over, tmp / f"{name}_full", comm=comm).run()
    t1 = time.time()
    s = simulation(config, over, tmp / f"{name}_split", comm=comm)
    assert s.run(observers=[lambda s: s.state.step == k])["status"] == "stopped_by_observer"
    res = simulation(config, over, tmp / f"{name}_split", comm=comm, resume=True).run()
    a = read_diagnostics(tmp / f"{name}_full" / "diagnostics.csv")
    b = read_diagnostics(tmp / f"{name}_split" / "diagnostics.csv")
    out = {"steps": (full["steps"], res["steps"]), "wall_full": round(t1 - t0, 1)}
    n = min(len(a["step"]), len(b["step"]))
    for key in ("dt", "max_speed", "front", "kinetic_energy"):
        x, y = np.asarray(a[key][k:n], float), np.asarray(b[key][k:n], float)
        rel = np.abs(x - y) / np.maximum(np.abs(x), 1e-300)
        out[key] = (float(rel[0]) if len(rel) else None, float(rel.max()) if len(rel) else None)
    fa = np.load(tmp / f"{name}_full" / "checkpoint.npz")
    fb = np.load(tmp / f"{name}_split" / "checkpoint.npz")
    fd = {}

    def nodal(f, key):
        pts = f[key.replace("values", "points")].reshape(-1, 2)
        val = f[key].reshape(len(pts), -1)
        order = np.lexsort((val[:, 0], pts[:, 1], pts[:, 0]))
        return pts[order], val[order]

    for key in fa.files:
        if key.endswith("values") and key in fb.files and fa[key].shape == fb[key].shape:
            (pa, x), (pb, y) = nodal(fa, key), nodal(fb, key)
            if not np.allclose(pa, pb, rtol=0, atol=1e-13):
                fd[key] = "nodes differ"
                continue
            fd[key] = float(np.abs(x - y).max() / max(np.abs(x).max(), 1e-300))
        elif key.endswith("values"):
            fd[key] = "shape differs"
    out["fields"] = fd
    print(name, json.dumps(out), flush=True)


if __name__ == "__main__":
    import tempfile

    tmp = Path(tempfile.mkdtemp())
    print("code", __import__("dpcollapse").__file__, flush=True)
    for name in sys.argv[1:]:
        try:
            run(name, tmp)
        except Exception as e:
            print(name, "ERROR", type(e).__name__, e, flush=True)
