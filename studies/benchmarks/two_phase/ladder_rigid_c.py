"""The rigid trapezoid on the two-phase model (the ladder's two-phase rung): c at the first
and last output, read back with ParaView's Xdmf3ReaderT, with ∫ c of each.

Usage: pvpython studies/benchmarks/two_phase/ladder_rigid_c.py RUN/solution.xdmf OUT.png
(RUN: the ladder's work folder ``rigid_tp``, from ``python -m studies ladder --two-phase``.)
"""
import sys
from pathlib import Path

import matplotlib
import numpy as np
from paraview import servermanager as sm
from paraview.simple import Xdmf3ReaderT
from vtk.util.numpy_support import vtk_to_numpy

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "tests"))
from pv_read_xdmf import dataset_of  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

reader = Xdmf3ReaderT(FileName=[sys.argv[1]])
times = reader.TimestepValues
fig, axes = plt.subplots(2, 1, figsize=(12, 5.5))
for ax, t in zip(axes, (times[0], times[-1])):
    reader.UpdatePipeline(t)
    ds = dataset_of(sm.Fetch(reader))
    pts = vtk_to_numpy(ds.GetPoints().GetData())[:, :2]
    cells = np.array([[ds.GetCell(i).GetPointId(j) for j in range(3)]
                      for i in range(ds.GetNumberOfCells())])
    tri, c = pts[cells], vtk_to_numpy(ds.GetCellData().GetArray("volume_fraction")).ravel()
    area = 0.5 * np.abs(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    print(f"t = {t:.4f} s: {len(c)} cells, integral of c {np.dot(area, c):.8e} m^2")
    pc = PolyCollection(tri, array=c, cmap="viridis", edgecolors="face", linewidths=0.1)
    pc.set_clim(0, 1)
    ax.add_collection(pc)
    ax.set_xlim(0, 1.2)
    ax.set_ylim(0, 0.3)
    ax.set_aspect("equal")
    ax.set_title(f"rigid trapezoid on the two-phase model, 1 cm cells: c at t = {t:.3f} s "
                 "(read by ParaView's Xdmf3ReaderT)", fontsize=9)
fig.colorbar(pc, ax=axes)
fig.savefig(sys.argv[2], dpi=90)
