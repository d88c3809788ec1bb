"""The a = 6.26 column at L0/32: where the granular phase moves faster than free fall.

    python studies/benchmarks/two_phase/overspeed.py RUN OUT.png [T]

RUN: a two-phase run directory (fields/ and diagnostics.csv); T the output time to show
(default: the output nearest 0.22 s). Left: c and |u| of the output at T (the white contour
is 2 √(g H0), Ritter's front speed of the inviscid dam break of depth H0: a frictional mass
moves slower); right: max |u| over the granular cells (c > 0.5, diagnostics.csv) and the
mass front's speed (d x_f/dt over 10 ms) against t, with 2 √(g H0).
"""

import csv
import glob
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402
from yield_weighting_heap import field  # noqa: E402


def main(run, out, when=0.22):
    g = 9.81
    cfg = yaml.safe_load(open(f"{run}/config.yaml"))
    h0 = cfg["geometry"]["height"]
    bound = 2.0 * np.sqrt(g * h0)
    files = sorted(glob.glob(f"{run}/fields/step_*.h5"))
    times = [field(h5py.File(fn), "volume_fraction")[0] for fn in files]
    f = h5py.File(files[int(np.argmin(np.abs(np.array(times) - when)))])
    xy, cells = f["Mesh/mesh/geometry"][:], f["Mesh/mesh/topology"][:]
    t, c = field(f, "volume_fraction")
    _, u = field(f, "velocity")
    tri = Triangulation(xy[:, 0], xy[:, 1], cells)
    speed = np.linalg.norm(u[:, :2], axis=1)
    rows = list(csv.DictReader(open(f"{run}/diagnostics.csv")))
    ts = np.array([float(r["t"]) for r in rows])
    top = np.array([float(r["max_speed"]) for r in rows])
    front = np.array([float(r["front"]) for r in rows])
    grid = np.arange(ts[0], ts[-1], 0.01)
    front_speed = np.gradient(np.interp(grid, ts, front), grid)

    fig = plt.figure(figsize=(13, 6.5))
    ax_c = fig.add_axes([0.05, 0.55, 0.55, 0.38])
    ax_u = fig.add_axes([0.05, 0.08, 0.55, 0.38])
    ax_t = fig.add_axes([0.7, 0.12, 0.28, 0.78])
    for ax in (ax_c, ax_u):
        ax.set_xlim(0, 0.5)
        ax.set_ylim(0, 0.2)
        ax.set_aspect("equal")
        ax.set_ylabel("y [m]")
    im = ax_c.tripcolor(tri, facecolors=c.ravel(), cmap="viridis", vmin=0, vmax=1)
    fig.colorbar(im, ax=ax_c, label="c")
    ax_c.set_title(f"volume fraction c, t = {t:.3f} s (L0/32 = 3.1 mm cells)")
    im = ax_u.tripcolor(tri, speed, cmap="magma", vmin=0, vmax=12, shading="gouraud")
    ax_u.tricontour(tri, speed, levels=[bound], colors="w", linewidths=0.8)
    fig.colorbar(im, ax=ax_u, label="|u| [m/s]")
    ax_u.set_title(f"|u|; white: 2 √(g H0) = {bound:.1f} m/s")
    ax_u.set_xlabel("x [m]")
    ax_t.plot(ts, top, lw=0.8, label="max |u|, cells with c > 0.5")
    ax_t.plot(grid, front_speed, color="C1", label="mass front's speed")
    ax_t.axhline(bound, color="k", ls="--", label="2 √(g H0) (Ritter)")
    ax_t.set_xlabel("t [s]")
    ax_t.set_ylabel("speed [m/s]")
    ax_t.set_ylim(0, 12)
    ax_t.legend(loc="upper left", fontsize=8)
    fig.savefig(out, dpi=100)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(float(a) for a in sys.argv[3:4]))
