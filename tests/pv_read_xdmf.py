"""Open an XDMF master file with ParaView's Xdmf3ReaderT (or an ADIOS2 VTX ``.bp`` folder
with its ADIOS2VTXReader) and print a JSON summary.

Usage: pvpython tests/pv_read_xdmf.py path/to/solution.xdmf [more.xdmf | vtx/nodes_000.bp ...]

pvpython prints its own noise, so each file's summary is one line starting with
``PV_SUMMARY_JSON:`` (in the order given; several files share one pvpython start-up).
Exit status 1 when a file does not open (its JSON then has an ``error`` key).
"""

import json
import os
import sys

MARK = "PV_SUMMARY_JSON:"


def dataset_of(data):
    """The first vtkDataSet in what Fetch returned (a composite for some readers)."""
    if data is None:
        return None
    if data.IsA("vtkCompositeDataSet"):
        it = data.NewIterator()
        it.InitTraversal()
        while not it.IsDoneWithTraversal():
            block = it.GetCurrentDataObject()
            if block is not None and block.IsA("vtkDataSet"):
                return block
            it.GoToNextItem()
        return None
    return data


def snapshot(reader, servermanager, t):
    reader.UpdatePipeline(t)
    ds = dataset_of(servermanager.Fetch(reader))
    if ds is None:
        raise RuntimeError(f"no dataset at t={t}")
    pd, cd = ds.GetPointData(), ds.GetCellData()
    first = list(ds.GetPoint(0)) if ds.GetNumberOfPoints() else None
    ranges = {}
    for data in (pd, cd):
        for i in range(data.GetNumberOfArrays()):
            arr = data.GetArray(i)
            ranges[arr.GetName()] = list(arr.GetRange(-1 if arr.GetNumberOfComponents() > 1 else 0))
    return {
        "time": t,
        "num_points": ds.GetNumberOfPoints(),
        "num_cells": ds.GetNumberOfCells(),
        "bounds": list(ds.GetBounds()),
        "first_point": first,
        "point_arrays": [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())],
        "cell_arrays": [cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())],
        "ranges": ranges,
    }


def main(path):
    from paraview import servermanager

    if path.endswith(".bp"):
        if not os.path.isdir(path):
            raise FileNotFoundError(path)
        from paraview.simple import ADIOS2VTXReader

        reader = ADIOS2VTXReader(FileName=path)
    else:
        if not os.path.isfile(path):
            raise FileNotFoundError(path)
        from paraview.simple import Xdmf3ReaderT

        reader = Xdmf3ReaderT(FileName=[path])
    reader.UpdatePipelineInformation()
    values = reader.TimestepValues
    # A single time step comes back as a bare float.
    times = [float(t) for t in values] if isinstance(values, (list, tuple)) or hasattr(
        values, "__iter__") else [float(values)]
    if not times:
        raise RuntimeError("the reader found no time steps")
    snapshots = [snapshot(reader, servermanager, t) for t in times]
    # The reader's array information is filled in by the first pipeline update.
    return {
        "file": path,
        "times": times,
        "point_arrays": list(reader.PointData.keys()),
        "cell_arrays": list(reader.CellData.keys()),
        "snapshots": snapshots,
        "first": snapshots[0] if snapshots else None,
        "last": snapshots[-1] if snapshots else None,
    }


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print("usage: pvpython pv_read_xdmf.py FILE.xdmf [FILE.xdmf ...]", file=sys.stderr)
        sys.exit(2)
    status = 0
    for path in sys.argv[1:]:
        try:
            result = main(path)
        except Exception as exc:  # report, don't let pvpython's noise hide it
            result, status = {"file": path, "error": f"{type(exc).__name__}: {exc}"}, 1
        print(MARK + json.dumps(result), flush=True)
    sys.exit(status)
