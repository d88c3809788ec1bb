"""Deposit fronts at fixed thicknesses: where the free surface of the last snapshot is δ high (issue 51).

    python studies/benchmarks/rigid_iso_thickness.py RUN [RUN ...] \
        [--deltas 0.001 0.002 0.005 0.01 0.02 0.05] [--time T]

The diagnostics' ``front`` is the mass's last point and ``thick_front`` the point where the
mass is last film_threshold = geometry.mesh_size/4 thick: both depend on the cell size by
construction. Here the free surface h(x) of each run's last solution.xdmf snapshot (its
boundary edges off the bed y = 0 and the wall x = 0, the upper envelope, linear between
vertices) gives x_δ = the largest x with h(x) ≥ δ, for fixed δ [m]: fronts that mean the
same on every mesh. Also the deposit height max h. ``--time T``: the snapshot nearest T
instead of the last (a deposit read before a late creep of its toe, or mid-flow).

The viscous/plastic reader is rigid_dx_dissipation.py's (same folder).
"""
import argparse
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rigid_dx_dissipation import snapshots  # noqa: E402


def surface(h5path):
    """Upper free-surface segments [(x0, y0, x1, y1)] of a snapshot's mesh."""
    with h5py.File(h5path, "r") as f:
        x = f["/Mesh/mesh/geometry"][:, :2]
        cells = f["/Mesh/mesh/topology"][:]
    edges = np.sort(np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    boundary = uniq[count == 1]
    a, b = x[boundary[:, 0]], x[boundary[:, 1]]
    on_bed = (np.abs(a[:, 1]) < 1e-9) & (np.abs(b[:, 1]) < 1e-9)
    on_wall = (np.abs(a[:, 0]) < 1e-9) & (np.abs(b[:, 0]) < 1e-9)
    keep = ~(on_bed | on_wall)
    return a[keep], b[keep]


def iso_front(a, b, delta):
    """Largest x where a surface segment is at height delta (or above it at its right end)."""
    best = -np.inf
    for (x0, y0), (x1, y1) in zip(a, b):
        lo, hi = min(y0, y1), max(y0, y1)
        if hi < delta:
            continue
        if lo >= delta:
            best = max(best, x0, x1)
        else:
            best = max(best, x0 + (delta - y0) * (x1 - x0) / (y1 - y0))
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--deltas", nargs="+", type=float, default=[0.001, 0.002, 0.005, 0.01, 0.02, 0.05])
    ap.add_argument("--time", type=float, default=None, help="the snapshot nearest this time [s]")
    args = ap.parse_args()
    print("run | t [s] | " + " | ".join(f"x at h = {d * 1e3:g} mm [m]" for d in args.deltas)
          + " | tip [m] | max h [m]")
    for run in args.runs:
        snaps = snapshots(run)
        t, h5, _ = snaps[-1] if args.time is None else min(snaps, key=lambda s: abs(s[0] - args.time))
        a, b = surface(h5)
        fronts = [iso_front(a, b, d) for d in args.deltas]
        tip = max(a[:, 0].max(), b[:, 0].max())
        height = max(a[:, 1].max(), b[:, 1].max())
        print(f"{Path(run).name} | {t:.3f} | " + " | ".join(f"{x:.5f}" for x in fronts)
              + f" | {tip:.5f} | {height:.5f}")


if __name__ == "__main__":
    main()
