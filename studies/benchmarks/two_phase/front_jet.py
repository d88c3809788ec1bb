"""The light fluid's jet ahead of the two-phase trapezoid's front: c and |u| near the bed.

    python studies/benchmarks/two_phase/front_jet.py OUT.png T "label=RUN" ["label=RUN" ...]

One row per run (two-phase run directories with fields/): left c, right |u| (log colour
scale) of the output nearest time T, in the window x 0.2–0.9 m, y 0–0.2 m, with the c = ½
contour on both.
"""

import glob
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402
from yield_weighting_heap import field, nodal  # noqa: E402


def nearest_output(run, when):
    files = sorted(glob.glob(f"{run}/fields/step_*.h5"))
    times = [field(h5py.File(fn), "volume_fraction")[0] for fn in files]
    return h5py.File(files[int(np.argmin(np.abs(np.array(times) - when)))])


def main(out, when, runs):
    fig, axes = plt.subplots(len(runs), 2, figsize=(13, 2.6 * len(runs)), squeeze=False)
    for row, spec in zip(axes, runs):
        label, run = spec.split("=", 1)
        f = nearest_output(run, when)
        xy, cells = f["Mesh/mesh/geometry"][:], f["Mesh/mesh/topology"][:]
        t, c = field(f, "volume_fraction")
        _, u = field(f, "velocity")
        tri = Triangulation(xy[:, 0], xy[:, 1], cells[:, :3])
        speed = np.maximum(np.linalg.norm(u[:, :2], axis=1), 1e-3)
        c = c.ravel()
        cv = nodal(xy, cells[:, :3], c)   # c at the vertices, for the contour
        a = row[0].tripcolor(tri, facecolors=c, vmin=0, vmax=1, cmap="viridis")
        fig.colorbar(a, ax=row[0], label="c")
        b = row[1].tripcolor(tri, speed, shading="gouraud", norm=LogNorm(0.01, 10), cmap="magma")
        fig.colorbar(b, ax=row[1], label="|u| [m/s]")
        for ax in row:
            ax.tricontour(tri, cv, levels=[0.5], colors="w", linewidths=0.8)
            ax.set_xlim(0.2, 0.9)
            ax.set_ylim(0, 0.2)
            ax.set_aspect("equal")
        row[0].set_title(f"{label}: c, t = {t:.3f} s")
        row[1].set_title(f"{label}: |u| (max {speed.max():.1f} m/s); white: c = 1/2")
    fig.tight_layout()
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), sys.argv[3:])
