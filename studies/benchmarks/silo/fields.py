"""The volume fraction c and the speed of silo runs, read back through ParaView (issue 28).

    pvpython studies/benchmarks/silo/fields.py dump RUN T OUT.npz       # ParaView's Xdmf3ReaderT
    python studies/benchmarks/silo/fields.py plot OUT.png A.npz:TITLE [B.npz:TITLE ...]

``dump`` reads RUN/solution.xdmf at time T with ParaView and stores the points, triangles, c
(cells) and velocity (points); ``plot`` draws c with speed contours 0.01, 0.05, 0.2 m/s
(white, orange, red). Two steps because this machine's pvpython cannot render off-screen.
"""
import sys

import numpy as np


def dump(run, t, out):
    from paraview import servermanager
    from paraview.simple import Xdmf3ReaderT
    from vtk.util.numpy_support import vtk_to_numpy

    reader = Xdmf3ReaderT(FileName=[f"{run}/solution.xdmf"])
    reader.UpdatePipeline(t)
    ds = servermanager.Fetch(reader)
    if ds.IsA("vtkCompositeDataSet"):
        it = ds.NewIterator()
        it.InitTraversal()
        ds = it.GetCurrentDataObject()
    np.savez(out, pts=vtk_to_numpy(ds.GetPoints().GetData()),
             conn=vtk_to_numpy(ds.GetCells().GetData()).reshape(-1, 4)[:, 1:],
             c=vtk_to_numpy(ds.GetCellData().GetArray("volume_fraction")),
             u=vtk_to_numpy(ds.GetPointData().GetArray("velocity")))


def plot(out, panels):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri

    fig, axes = plt.subplots(1, len(panels), figsize=(3.2 * len(panels) + 1.5, 4.6))
    for ax, panel in zip(np.atleast_1d(axes), panels):
        path, title = panel.split(":", 1)
        d = np.load(path)
        tri = mtri.Triangulation(d["pts"][:, 0], d["pts"][:, 1], d["conn"])
        image = ax.tripcolor(tri, facecolors=d["c"], vmin=0, vmax=1, cmap="viridis")
        speed = np.linalg.norm(d["u"][:, :2], axis=1)
        ax.tricontour(tri, speed, levels=[0.01, 0.05, 0.2], colors=["w", "orange", "r"],
                      linewidths=0.7)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=8)
        ax.set_xlabel("x [m]")
    fig.colorbar(image, ax=axes, shrink=0.7, label="c")
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    if sys.argv[1] == "dump":
        dump(sys.argv[2], float(sys.argv[3]), sys.argv[4])
    else:
        plot(sys.argv[2], sys.argv[3:])
