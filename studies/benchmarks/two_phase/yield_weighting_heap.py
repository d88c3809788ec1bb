"""c on the static heap's flank at the last output of each run, one panel per run (issue 27,
docs/benchmarks/2026-12-04-two-phase-yield-weighting.md):

    python studies/benchmarks/two_phase/yield_weighting_heap.py OUT.png LABEL=RUN_DIR...

Reads RUN_DIR/fields/step_*.h5 (the DG0 volume fraction of the last one, and the first for
the initial interface c = ½, drawn as a line) with h5py.
"""

import glob
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.tri import Triangulation


def field(f, name):
    """(t, values) of the function ``name`` in an open output file ``f`` (one time each)."""
    group = f["Function/" + name]
    key = list(group.keys())[0]
    return float(key.replace("_", ".")), group[key][:]


def fraction(path):
    with h5py.File(path) as f:
        x = f["Mesh/mesh/geometry"][:]
        cells = f["Mesh/mesh/topology"][:]
        t, c = field(f, "volume_fraction")
        return x, cells, c[:, 0], t


def nodal(x, cells, c):
    """The cell values c at the vertices: the mean over the cells around each vertex."""
    counts = np.maximum(np.bincount(cells.ravel(), minlength=len(x)), 1)
    return np.bincount(cells.ravel(), weights=np.repeat(c, 3), minlength=len(x)) / counts


def main(out, runs):
    fig, axes = plt.subplots(len(runs), 1, figsize=(7, 1.9 * len(runs)), sharex=True)
    for ax, item in zip(np.atleast_1d(axes), runs):
        label, run = item.split("=", 1)
        files = sorted(glob.glob(f"{run}/fields/step_*.h5"),
                       key=lambda s: int(s.rsplit("_", 1)[1][:-3]))
        x, cells, c, t = fraction(files[-1])
        x0, cells0, c0, _ = fraction(files[0])
        im = ax.tripcolor(Triangulation(x[:, 0], x[:, 1], cells), facecolors=np.clip(c, 0, 1),
                          cmap="viridis", vmin=0, vmax=1)
        ax.tricontour(Triangulation(x0[:, 0], x0[:, 1], cells0), nodal(x0, cells0, c0),
                      levels=[0.5], colors="w", linewidths=0.8)
        ax.set_xlim(0.1, 0.5)
        ax.set_ylim(0, 0.12)
        ax.set_aspect("equal")
        ax.set_title(f"{label}: c at t = {t:.2f} s (white: c = 1/2 at t = 0)", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.8, label="c")
    fig.savefig(out, dpi=130, bbox_inches="tight")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
