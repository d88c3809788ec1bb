"""The free surface at rest of several runs, overlaid (issue 25: no new oscillation at the toe).

    python benchmarks/deposit_surface.py --png docs/figures/time_order_deposit.png LABEL=RUN_DIR ...

Reads each run's ``checkpoint.npz`` (the mesh at the last accepted step) and draws its
free-surface edges (tag SURFACE), the whole deposit and a close-up of the toe.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dpcollapse.geometry.mesher import SURFACE


def surface_edges(run: Path) -> np.ndarray:
    """(n, 2, 2): the free-surface edges of the run's last mesh [m]."""
    z = np.load(run / "checkpoint.npz", allow_pickle=True)
    x = z["mesh_x"][:, :2]
    edges = z["mesh_edges"][z["mesh_edge_tags"] == SURFACE]
    return x[edges]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--png", type=Path, required=True)
    ap.add_argument("--toe", type=float, nargs=2, default=(0.55, 0.68), help="x range of the close-up [m]")
    ap.add_argument("runs", nargs="+", help="LABEL=RUN_DIR")
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    fig, axes = plt.subplots(2, 1, figsize=(11, 7))
    for i, item in enumerate(args.runs):
        label, run = item.split("=", 1)
        segs = surface_edges(Path(run))
        color = f"C{i}"
        for ax in axes:
            ax.add_collection(LineCollection(segs, colors=color, lw=1.2, label=label))
            ax.plot(segs[:, :, 0].ravel(), segs[:, :, 1].ravel(), ".", color=color, ms=2.5)
        print(f"{label}: front {segs[:, :, 0].max():.5f} m, {len(segs)} surface edges")
    axes[0].set_xlim(0.0, args.toe[1])
    axes[0].set_ylim(0.0, 0.23)
    axes[0].set_aspect("equal")
    axes[1].set_xlim(*args.toe)
    axes[1].set_ylim(0.0, 0.05)
    axes[0].set_title("free surface at rest")
    axes[1].set_title("the toe")
    for ax in axes:
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)


if __name__ == "__main__":
    main()
