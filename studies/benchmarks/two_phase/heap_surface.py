"""The largest change of a two-phase run's surface between its first and last output
(docs/benchmarks/2026-12-04-cut-cell-pressure.md, §1):

    python studies/benchmarks/two_phase/heap_surface.py RUN_DIR DX

h(x) = ∫ c dy per column of width DX [m] (cells binned by their centroid's x, Σ c_K |K| / DX),
read from the run's fields/step_*.h5 (the XDMF output); prints max |h_last − h_first| in m
and in DX.
"""

import glob
import sys

import h5py
import numpy as np


def column_heights(path: str, dx: float) -> np.ndarray:
    with h5py.File(path) as f:
        cells = f["/Mesh/mesh/topology"][:]
        x = f["/Mesh/mesh/geometry"][:]
        name = list(f["/Function/volume_fraction"].keys())[0]
        c = f["/Function/volume_fraction/" + name][:].ravel()
    p = x[cells][:, :, :2]
    area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                        - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    columns = np.floor(p[:, :, 0].mean(axis=1) / dx).astype(int)
    return np.bincount(columns, weights=c * area) / dx


def main() -> None:
    run, dx = sys.argv[1], float(sys.argv[2])
    files = sorted(glob.glob(run + "/fields/step_*.h5"))
    first, last = column_heights(files[0], dx), column_heights(files[-1], dx)
    n = min(len(first), len(last))
    change = np.abs(last[:n] - first[:n]).max()
    print(f"{run}: max |dh| {change:.3g} m = {change / dx:.4f} dX over {len(files)} outputs")


if __name__ == "__main__":
    main()
