"""Issue 27's rest rule, read from two runs: the run that came to rest (run.json's t = T)
and its continuation to 2T with the rest rule held off. Prints the mass front, thickness
front and top height at T and at the end, their changes in % of H0, and the largest granular
speed after T. Both fronts of diagnostics.csv are read per cell (a mass front steps by a
whole cell when one toe cell's c crosses ½); where both runs hold a checkpoint.npz (written at
their last step: T and 2T) the script also prints a sub-cell mass front, the furthest x of
the c = ½ contour of c averaged to the vertices (area-weighted, linear along each edge), above
FLOOR [m] (default 0; on an erodible layer 2 h_e, as the diagnostics' mass front).

    python studies/benchmarks/two_phase/rest_check.py RUN_AT_REST RUN_CONTINUED H0 [FLOOR]
"""

import csv
import json
import sys
from pathlib import Path

import numpy as np


def contour_front(checkpoint: Path, floor: float = 0.0, level: float = 0.5) -> tuple[float, float]:
    """(furthest x [m] of the c = level contour of the vertex-averaged c at y ≥ floor, t [s]) of a
    two-phase checkpoint.npz (mesh_x, mesh_cells, the DG0 volume fraction per cell)."""
    data = np.load(checkpoint)
    points, cells = data["mesh_x"], data["mesh_cells"]
    fraction = data["x_volume_fraction_values"][:, 0, 0]
    v = data["x_volume_fraction_vertices"]
    area = 0.5 * np.abs((v[:, 1, 0] - v[:, 0, 0]) * (v[:, 2, 1] - v[:, 0, 1])
                        - (v[:, 2, 0] - v[:, 0, 0]) * (v[:, 1, 1] - v[:, 0, 1]))
    weighted, weight = np.zeros(len(points)), np.zeros(len(points))
    for k in range(3):
        np.add.at(weighted, cells[:, k], fraction * area)
        np.add.at(weight, cells[:, k], area)
    at_vertex = weighted / weight
    front = -np.inf
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, b = cells[:, i], cells[:, j]
        ca, cb = at_vertex[a], at_vertex[b]
        cross = ((ca - level) * (cb - level) <= 0) & (ca != cb)
        s = (level - ca[cross]) / (cb[cross] - ca[cross])
        x = points[a[cross], 0] + s * (points[b[cross], 0] - points[a[cross], 0])
        y = points[a[cross], 1] + s * (points[b[cross], 1] - points[a[cross], 1])
        x = x[y >= floor - 1e-12]
        if x.size:
            front = max(front, float(x.max()))
    return front, float(json.loads(str(data["state"]))["t"])


def main(rest: str, continued: str, height: float, floor: float = 0.0) -> None:
    t_rest = json.load(open(f"{rest}/run.json"))["summary"]["t"]
    with open(f"{continued}/diagnostics.csv") as fh:
        rows = list(csv.DictReader(fh))
    start = min(rows, key=lambda r: abs(float(r["t"]) - t_rest))
    end = rows[-1]
    for label, row in (("T ", start), ("2T", end)):
        print(f"{label} t = {float(row['t']):.3f} s: front {float(row['front']):.4f} m, thickness "
              f"front {float(row['thick_front']):.4f} m, top {float(row['max_height']):.5f} m, "
              f"granular max speed {float(row['max_speed']):.2e} m/s")
    for key in ("front", "thick_front", "max_height"):
        change = float(end[key]) - float(start[key])
        print(f"  {key}: {change:+.2e} m = {100 * change / height:+.2f} % of H0")
    after = max(float(r["max_speed"]) for r in rows if float(r["t"]) >= t_rest)
    print(f"largest granular speed from T on: {after:.2e} m/s")
    checkpoints = [Path(run) / "checkpoint.npz" for run in (rest, continued)]
    if all(path.exists() for path in checkpoints):
        (x0, t0), (x1, t1) = (contour_front(path, floor) for path in checkpoints)
        print(f"sub-cell mass front (c = 1/2 contour): {x0:.5f} m at t = {t0:.3f} s, "
              f"{x1:.5f} m at t = {t1:.3f} s: {x1 - x0:+.2e} m = {100 * (x1 - x0) / height:+.2f} % of H0")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]) if len(sys.argv) > 4 else 0.0)
