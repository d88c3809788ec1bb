"""Deposit profiles h(x) of the rigid-bed trapezoid: two-phase runs against moving-mesh runs
(docs/benchmarks/2026-12-05-two-phase-inertia.md).

    python studies/benchmarks/two_phase/deposit_profiles.py OUT.png DX [--toe=X0,X1,HMAX] "label=RUN[@DX]" ...

h(x) = Σ c_K |K ∩ S| / DX over the column S = [x, x + DX) × ℝ (exact triangle-strip overlaps,
``remap.strip_overlaps``) of the last output (fields/step_*.h5): c the volume fraction of a two-phase
run, 1 on a moving
mesh (the mesh is the material); DX after a run: its own width. The same definition for both models;
printed: the front at
h ≥ 1, 2, 5, 10, 20 mm (right edge of the last such column) and the largest h. The right panel shows the
toe in
[X0, X1] × [0, HMAX] (default the trapezoid's 0.45, 0.9, 0.05 m). Labels starting with "MM" are drawn dashed.
"""

import glob
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from dpcollapse.models.two_phase.remap import strip_overlaps


def profile(run: str, dx: float) -> tuple[float, np.ndarray]:
    """(t, h per column) of the run's last output."""
    path = sorted(glob.glob(run + "/fields/step_*.h5"))[-1]
    with h5py.File(path) as f:
        cells = f["/Mesh/mesh/topology"][:]
        x = f["/Mesh/mesh/geometry"][:]
        if "volume_fraction" in f["/Function"]:
            key = list(f["/Function/volume_fraction"].keys())[0]
            c = f["/Function/volume_fraction/" + key][:].ravel()
        else:
            key = list(f["/Function/velocity"].keys())[0]
            c = np.ones(len(cells))
    t = float(key.replace("_", "."))
    p = x[cells][:, :3, :2]
    count = int(np.ceil(p[:, :, 0].max() / dx - 1e-9))
    cell, strip, overlap = strip_overlaps(p, dx, count)
    return t, np.bincount(strip, weights=c[cell] * overlap, minlength=count) / dx


def main() -> None:
    out, dx = sys.argv[1], float(sys.argv[2])
    runs = [arg for arg in sys.argv[3:] if not arg.startswith("--toe=")]
    window = [arg for arg in sys.argv[3:] if arg.startswith("--toe=")]
    x0, x1, hmax = (float(v) for v in window[-1][len("--toe="):].split(",")) if window else (0.45, 0.9, 0.05)
    fig, (ax, toe) = plt.subplots(1, 2, figsize=(12, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    for arg in runs:
        label, run = arg.split("=", 1)
        run, width = (run.split("@") + [dx])[:2]
        width = float(width)
        t, h = profile(run, width)
        xs = (np.arange(len(h)) + 0.5) * width
        fronts = []
        for threshold in (1e-3, 2e-3, 5e-3, 1e-2, 2e-2):
            idx = np.nonzero(h >= threshold)[0]
            fronts.append((idx[-1] + 1) * width if len(idx) else float("nan"))
        print(f"{label}: t = {t:.3f} s, front at h ≥ 1 / 2 / 5 / 10 / 20 mm: "
              + " / ".join(f"{f:.3f}" for f in fronts) + f" m, max h {h.max():.4f} m")
        style = "--" if label.startswith("MM") else "-"
        ax.plot(xs, h, style, label=f"{label} (t = {t:.2f} s)")
        toe.plot(xs, h, style)
    ax.set_xlabel("x [m]"), ax.set_ylabel("h = ∫ c dy per column  [m]")
    ax.set_xlim(0, None), ax.set_ylim(0, None), ax.grid(alpha=0.3), ax.legend(fontsize=7)
    toe.set_xlim(x0, x1), toe.set_ylim(0, hmax), toe.grid(alpha=0.3)
    toe.set_xlabel("x [m]"), toe.set_title("the toe", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


if __name__ == "__main__":
    main()
