"""The body of revolution of an axisymmetric run (``geometry.symmetry: axisymmetric``) in ParaView.

Usage (ParaView's Python, not the project's)::

    pvpython scripts/paraview_revolve.py RUN/solution.xdmf [--time T] [--resolution N]
                                         [--save body.vtp]

The run's XDMF holds the (r, z) half-plane with the axis at x = 0 (x = r, y = z). The
pipeline is the one docs/axisymmetric.md gives for the GUI:

1. ``Xdmf3ReaderT`` (the file; ParaView's "XDMF Reader (Top Level Partition)"),
2. ``ExtractSurface`` (the rotational extrusion sweeps polygonal data: the triangles and
   the boundary of the half-plane),
3. ``Transform``, Rotate (90, 0, 0): the plane's y (= z, up) becomes the 3D z axis, so
   the axis of revolution is the 3D z axis,
4. ``RotationalExtrusion``, Angle 360, Resolution N (default 72 sectors, 5°).

Prints one line ``PV_REVOLVE_JSON:{...}`` (the time, the revolved data's bounds, points and
point arrays); ``--save`` writes the revolved surface (.vtp). Exit 1 when the file does not
open.
"""

import argparse
import json
import os
import sys

MARK = "PV_REVOLVE_JSON:"


def revolve(path: str, time: float | None = None, resolution: int = 72):
    """(reader, extrusion, time): the pipeline of the module docstring at ``time`` (the last
    step when None)."""
    from paraview.simple import ExtractSurface, RotationalExtrusion, Transform, Xdmf3ReaderT

    if not os.path.isfile(path):
        raise FileNotFoundError(path)
    reader = Xdmf3ReaderT(FileName=[path])
    reader.UpdatePipelineInformation()
    values = reader.TimestepValues
    times = [float(t) for t in values] if hasattr(values, "__iter__") else [float(values)]
    t = times[-1] if time is None else time
    surface = ExtractSurface(Input=reader)
    upright = Transform(Input=surface)
    upright.Transform = "Transform"
    upright.Transform.Rotate = [90.0, 0.0, 0.0]     # (r, z, 0) -> (r, 0, z)
    body = RotationalExtrusion(Input=upright)
    body.Angle = 360.0
    body.Resolution = resolution
    body.UpdatePipeline(t)
    return reader, body, t


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("xdmf")
    parser.add_argument("--time", type=float, default=None, help="the step's time (last: default)")
    parser.add_argument("--resolution", type=int, default=72, help="sectors over 360 degrees")
    parser.add_argument("--save", default=None, help="write the body as a .vtp file")
    args = parser.parse_args(argv)
    try:
        from paraview import servermanager
        from paraview.simple import SaveData

        _, body, t = revolve(args.xdmf, args.time, args.resolution)
        data = servermanager.Fetch(body)
        if data is None or data.GetNumberOfPoints() == 0:
            raise RuntimeError("the revolved body is empty")
        points = data.GetPointData()
        result = {"file": args.xdmf, "time": t, "bounds": list(data.GetBounds()),
                  "num_points": data.GetNumberOfPoints(),
                  "point_arrays": [points.GetArrayName(i) for i in range(points.GetNumberOfArrays())]}
        if args.save:
            SaveData(args.save, proxy=body)
            result["saved"] = args.save
        status = 0
    except Exception as exc:  # one line, not pvpython's noise
        result, status = {"file": args.xdmf, "error": f"{type(exc).__name__}: {exc}"}, 1
    print(MARK + json.dumps(result), flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
