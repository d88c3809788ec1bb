"""The silo (flat-bottomed bin) and the hopper (seed 004's hour glass; Beverloo's law).

A bin of width W filled to the height H with granular material under the light fluid, an
orifice of width D centred in its bottom; its half [0, W/2] is meshed, x = 0 the symmetry
line (slip). The bottom is flat (``geometry.hopper_angle`` null) or a hopper whose walls
converge to the orifice's edge at the half-angle β from the vertical, rising to
y_h = (W − D) / (2 tan β) where the vertical wall begins. The vessel's sides (CCW)::

    orifice  [0, D/2] × {0}          outflow: σ n = −p_a n, p_a the ambient light fluid's
                                     hydrostatic pressure (zero at the open top)
    bed      [D/2, W/2] × {0}        the bottom of the flat bin (``boundary.bed_condition``)
    wall     (D/2, 0) → (W/2, y_h)   the hopper's slanted wall (Coulomb μ_w on p, Nitsche u·n = 0)
    right    x = W/2                 the side wall (Coulomb μ_w = ``boundary.wall_friction_angle``)
    surface  y = bin_height          the open top (σ n = 0): the light fluid enters here
    left     x = 0                   the symmetry line (slip)

The mesh (gmsh, Frontal-Delaunay) has cells of ``geometry.orifice_mesh_size`` at the orifice's
centre and edge, graded linearly along the sides to ``geometry.mesh_size``. The material at
t = 0 is the bin below y = H (a convex polygon: c is its exact overlap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpcollapse.geometry.mesher import (
    BED,
    LEFT,
    ORIFICE,
    RIGHT,
    SURFACE,
    WALL,
    TaggedMesh,
    mesh_polygon,
    write_polygon_msh,
)
from dpcollapse.scenes.base import Boundary, BoundaryKind, Container, SceneSections, top_extent


@dataclass(frozen=True)
class SiloScene(SceneSections):
    """Holds ``config.geometry.SiloGeometry`` (W, H, the vessel's height, D, β, the cell sizes)
    and the boundary section (``SceneSections``: the bed condition, μ_b, μ_w); it starts at
    rest."""

    shape = "silo"

    def floor(self, x):
        """y of the vessel's bottom at x ∈ [D/2, W/2] (the hopper wall; 0 on the flat bin)."""
        g = self.geometry
        if g.hopper_angle is None:
            return np.zeros_like(np.asarray(x, dtype=float))
        half = 0.5 * g.orifice_width
        return (np.asarray(x, dtype=float) - half) / math.tan(math.radians(g.hopper_angle))

    def polygon(self):
        """CCW vertices and edge tags of the half vessel (the module's table)."""
        g = self.geometry
        r, d, top, yh = 0.5 * g.width, 0.5 * g.orifice_width, g.bin_height, g.hopper_top
        points = np.array([[0.0, 0.0], [d, 0.0], [r, yh], [r, top], [0.0, top]])
        bottom = WALL if g.hopper_angle is not None else BED
        return points, np.array([ORIFICE, bottom, RIGHT, SURFACE, LEFT], dtype=np.int32)

    def region(self) -> np.ndarray:
        """The material at t = 0: the half vessel below y = H (convex, CCW)."""
        g = self.geometry
        r, d, h, yh = 0.5 * g.width, 0.5 * g.orifice_width, g.fill_height, g.hopper_top
        if h >= yh:
            return np.array([[0.0, 0.0], [d, 0.0], [r, yh], [r, h], [0.0, h]])
        x = d + h * math.tan(math.radians(g.hopper_angle))
        return np.array([[0.0, 0.0], [d, 0.0], [x, h], [0.0, h]])

    def boundaries(self) -> tuple[Boundary, ...]:
        """The orifice (outflow), the bottom or the hopper's wall, the side wall, the open top,
        the symmetry line."""
        mu_wall = self.boundary.mu_wall
        wall = BoundaryKind.COULOMB if mu_wall > 0 else BoundaryKind.SLIP
        points, _ = self.polygon()
        if self.geometry.hopper_angle is None:
            bottom = self.bed()
        else:
            dx, dy = points[2] - points[1]
            length = math.hypot(dx, dy)
            bottom = Boundary(WALL, "hopper", wall, (dy / length, -dx / length), friction=mu_wall)
        return (Boundary(ORIFICE, "orifice", BoundaryKind.OUTFLOW, (0.0, -1.0),
                         reference=(0.0, self.geometry.bin_height)),
                bottom,
                Boundary(RIGHT, "wall", wall, (1.0, 0.0), friction=mu_wall),
                Boundary(SURFACE, "top", BoundaryKind.FREE_SURFACE),
                Boundary(LEFT, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0)))

    def size(self, cell_size: float):
        """(point, tag) → target size: the orifice's size at its centre and edge, else
        ``cell_size``."""
        fine = min(self.geometry.orifice_mesh_size or cell_size, cell_size)
        edge = 0.5 * self.geometry.orifice_width

        def size(point, tag):
            at_orifice = abs(point[1]) < 1e-12 and point[0] <= edge * (1 + 1e-12)
            return fine if at_orifice else cell_size

        return size

    def container(self, box=None) -> Container:
        """The half vessel (its own, not the model's box)."""
        def mesh(comm, cell_size):
            points, tags = self.polygon() if comm.rank == 0 else (None, None)
            return mesh_polygon(comm, points, tags, cell_size, size=self.size(cell_size))

        return Container(mesh, self.boundaries(), (self.region(),), 0.5 * self.geometry.width,
                         self.geometry.bin_height, floor=self.floor)

    def mesh(self, comm) -> TaggedMesh:
        return self.container().mesh(comm, self.mesh_size)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        points, tags = self.polygon()
        write_polygon_msh(path, points, tags, self.mesh_size, size=self.size(self.mesh_size))
        return path

    def initial_velocity(self):
        return lambda x: np.zeros((2, x.shape[1]))

    def extent(self, x):
        return top_extent(x)
