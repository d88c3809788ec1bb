"""Where the static heap of the two-phase model flows, read back by ParaView (issue 27).

    pvpython studies/benchmarks/two_phase/static_heap_probe.py RUN/solution.xdmf [FLANK_DEG MU_S]

RUN is the heap run of docs/benchmarks/2026-12-04-two-phase-static-heap.md (height 0.1 m,
base 0.4 m, flank at FLANK_DEG = 20°, μ_s = MU_S = tan 25.5°, 1 cm cells). Per output time,
for the cells of the flank (x beyond the top's end + 2 cm), by volume fraction c: the median
speed |u| at the cell centre, and the cell pressure against the weight of the grains above the
cell centre in its column, ρ g ∫ c dy (the column: cell centres within 5 mm in x; 1 cm
squares cut in two triangles, 0.5 cm per centre). The yield test of the mixture law on a slope
θ: c μ_s p ≥ tan θ p, i.e. a cell holds only where c ≥ tan θ / μ_s.
"""

import sys

import numpy as np
from paraview import servermanager as sm
from paraview.simple import CellCenters, PointDatatoCellData, XDMFReader
from vtk.numpy_interface import dataset_adapter as dsa

RHO, G, HEIGHT, BASE, CELL = 1550.0, 9.81, 0.1, 0.4, 0.01
flank = np.radians(float(sys.argv[2]) if len(sys.argv) > 2 else 20.0)
mu_s = float(sys.argv[3]) if len(sys.argv) > 3 else np.tan(np.radians(25.5))
reader = XDMFReader(FileNames=[sys.argv[1]])
reader.UpdatePipelineInformation()
times = reader.TimestepValues
centres = CellCenters(Input=PointDatatoCellData(Input=reader))
top_end = BASE - HEIGHT / np.tan(flank)
print(f"the mixture holds on the flank where c >= tan(flank)/mu_s = {np.tan(flank) / mu_s:.2f}")
for t in (times[1], times[len(times) // 2], times[-1]):
    centres.UpdatePipeline(t)
    data = dsa.WrapDataObject(sm.Fetch(centres))
    x = np.asarray(data.Points)[:, :2]
    c = np.asarray(data.PointData["volume_fraction"])
    p = np.asarray(data.PointData["pressure"])
    speed = np.linalg.norm(np.asarray(data.PointData["velocity"])[:, :2], axis=1)
    on_flank = x[:, 0] > top_end + 2 * CELL
    weight = np.array([RHO * G * (c[(np.abs(x[:, 0] - xk) < 0.5 * CELL) & (x[:, 1] > yk)].sum()
                                  * 0.5 * CELL + 0.5 * c[k] * CELL)
                       for k, (xk, yk) in enumerate(x)])
    print(f"t = {t:.2f} s")
    for lo, hi in ((0.05, 0.3), (0.3, 0.5), (0.5, 0.7), (0.7, 0.85), (0.85, 0.99), (0.99, 2.0)):
        cells = on_flank & (c > lo) & (c <= hi)
        if not cells.any():
            continue
        print(f"  c in ({lo:.2f}, {min(hi, 1.0):.2f}]: {cells.sum():4d} cells, |u| median "
              f"{np.median(speed[cells]) * 1e3:7.2f} mm/s, max {speed[cells].max() * 1e3:7.2f} mm/s, "
              f"p / weight above median {np.median(p[cells] / np.maximum(weight[cells], 1e-12)):.2f}")
    light = on_flank & (c <= 0.05)
    print(f"  light fluid over the flank (c <= 0.05): |u| max {speed[light].max() * 1e3:.1f} mm/s")
