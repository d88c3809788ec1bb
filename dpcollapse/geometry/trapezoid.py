"""The trapezoidal granular mass of seed 000 over a rigid bed, in slope coordinates.

Vertices (0, 0), (l0, 0), (l0 − h0 / tan α0, h0), (0, h0): left wall x = 0, bed y = 0,
base length l0 from the wall to the toe, and the right flank rising at angle α0 back
over the mass (our reading of seed 000; see shared/reference/README.md). Edges are tagged
bed, free surface (flank and top) and wall.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from mpi4py import MPI

from dpcollapse.geometry.mesher import (BED, SURFACE, WALL, TaggedMesh, mesh_polygon,
                                        read_msh, write_polygon_msh)


def trapezoid_polygon(height: float, base_length: float, flank_angle_deg: float):
    """CCW vertices and edge tags of the trapezoid (edge i joins vertex i and i+1)."""
    top = base_length - height / math.tan(math.radians(flank_angle_deg))
    points = np.array([[0.0, 0.0], [base_length, 0.0], [top, height], [0.0, height]])
    tags = np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)
    return points, tags


def _polygon(cfg):
    g = cfg.geometry
    return trapezoid_polygon(g.height, g.base_length, g.flank_angle)


def build_mesh(cfg, comm: MPI.Comm = MPI.COMM_WORLD) -> TaggedMesh:
    """The initial mesh of the scene: ``geometry.mesh_file`` if given, else the periodic
    layer or the trapezoid."""
    g = cfg.geometry
    if g.mesh_file:
        return read_msh(comm, g.mesh_file)
    if g.shape == "layer":
        from dpcollapse.geometry.layer import layer_mesh

        return layer_mesh(comm, g.base_length, g.height, g.mesh_size)
    points, tags = _polygon(cfg) if comm.rank == 0 else (None, None)
    return mesh_polygon(comm, points, tags, g.mesh_size, g.surface_mesh_size)


def write_msh(cfg, path: Path) -> Path:
    """``dpcollapse mesh``: write the initial gmsh mesh so it can be inspected."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    points, tags = _polygon(cfg)
    write_polygon_msh(path, points, tags, cfg.geometry.mesh_size, cfg.geometry.surface_mesh_size)
    return path
