"""c at the rest time T and at 2T, one panel each, the c = ½ contour of T drawn on the 2T
panel (issue 27, docs/benchmarks/2026-12-04-two-phase-rest-grains.md):

    python studies/benchmarks/two_phase/rest_grains_figure.py OUT.png LABEL=RUN_DIR@T ...

Reads the output nearest each time from RUN_DIR/fields/step_*.h5 (the DG0 volume fraction)
with ``yield_weighting_heap.fraction``; the view is the box of the cells with c > 0.01, padded.
"""

import glob
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.tri import Triangulation
from yield_weighting_heap import fraction, nodal  # the DG0 volume fraction of one output (h5py)


def read(path):
    x, cells, c, t = fraction(path)
    return x, cells, np.clip(c, 0, 1), t


def nearest(run, t):
    fields = [read(p) for p in glob.glob(f"{run}/fields/step_*.h5")]
    return min(fields, key=lambda f: abs(f[3] - t))


def main(out, items):
    fig, axes = plt.subplots(len(items), 2, figsize=(11, 2.2 * len(items)), squeeze=False)
    for row, item in zip(axes, items):
        label, rest = item.split("=", 1)
        run, t = rest.rsplit("@", 1)
        first = nearest(run, float(t))
        second = nearest(run, 2 * float(t))
        x, cells, c, _ = first
        grains = cells[c > 0.01].ravel()
        lo, hi = x[grains, :2].min(axis=0), x[grains, :2].max(axis=0)
        pad = 0.05 * (hi - lo).max()
        for ax, (xs, cs, values, time) in zip(row, (first, second)):
            im = ax.tripcolor(Triangulation(xs[:, 0], xs[:, 1], cs), facecolors=values,
                              cmap="viridis", vmin=0, vmax=1)
            ax.tricontour(Triangulation(x[:, 0], x[:, 1], cells), nodal(x, cells, c),
                          levels=[0.5], colors="w", linewidths=0.8)
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(0, hi[1] + pad)
            ax.set_aspect("equal")
            ax.set_title(f"{label}: c at t = {time:.3f} s (white: c = 1/2 at T)", fontsize=8)
    fig.colorbar(im, ax=axes, shrink=0.8, label="c")
    fig.savefig(out, dpi=120, bbox_inches="tight")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
