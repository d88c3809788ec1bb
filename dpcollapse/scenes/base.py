r"""What a scene tells the models: its mesh, the kind of each boundary, its initial state.

A scene builds the initial mesh of the mass with cell tags (material regions) and facet
tags, and states for each facet tag one :class:`Boundary`: its kind, with the outward unit
normal n of a straight side (tangent t = (−n_y, n_x), the counter-clockwise direction)::

    no_slip        u = 0
    coulomb        u·n = 0,  σ_T = −μ [p − σ'_nn]_+ u_T/|u_T|      (Coulomb friction μ)
    slip           u·n = 0,  σ_T = 0                              (frictionless; symmetry)
    free_surface   σ n = 0  (p = 0 for the pressure preconditioner; ALE: (w − u)·n = 0)
    outflow        σ n = −p_a n, p_a = ρ_a f·(x − x_ref) the ambient light fluid's
                   hydrostatic pressure (zero at the open top's point x_ref): an orifice
    periodic       u(x) = u(x + translation) on the side that carries the translation

u·n = 0 is imposed strongly on the velocity component along n where the side is parallel to
an axis (:attr:`Boundary.axis`), and weakly by Nitsche's method on a slanted side
(``forms.no_penetration``: consistent, exact for a solution in the space). The mesh velocity
of a moving domain has w·n = 0 on every solid side, so nodes slide along it (strongly on
one component, or by removing the normal part of w at the side's nodes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Protocol

import numpy as np

from dpcollapse.fronts import front_thickness
from dpcollapse.geometry.mesher import (
    BED,
    LEFT,
    RIGHT,
    SURFACE,
    WALL,
    TaggedMesh,
    mesh_polygon,
    read_msh,
    write_polygon_msh,
)
from dpcollapse.geometry.rectangle import structured_rectangle


class BoundaryKind(str, Enum):  # noqa: UP042 (StrEnum would change str() of a kind)
    NO_SLIP = "no_slip"
    COULOMB = "coulomb"
    SLIP = "slip"
    FREE_SURFACE = "free_surface"
    PERIODIC = "periodic"
    OUTFLOW = "outflow"


#: Kinds with no penetration u·n = 0 (and w·n = 0 for the mesh velocity).
SOLID = (BoundaryKind.NO_SLIP, BoundaryKind.COULOMB, BoundaryKind.SLIP)


@dataclass(frozen=True)
class Boundary:
    """One tagged side of a scene.

    tag: facet tag; name: names its friction term ``<name>_friction``; normal: outward unit
    normal of a straight side (None for the free surface); friction: μ (coulomb);
    translation: on the slave side of a periodic pair, the shift onto the master side;
    reference: on an outflow side, a point x_ref of the open top (p_a(x_ref) = 0).
    """

    tag: int
    name: str
    kind: BoundaryKind
    normal: tuple[float, float] | None = None
    friction: float = 0.0
    translation: tuple[float, float] | None = None
    reference: tuple[float, float] | None = None

    @property
    def tangent(self) -> tuple[float, float]:
        """t = (−n_y, n_x)."""
        nx, ny = self.normal
        return (-ny, nx)

    @property
    def axis(self) -> int | None:
        """The velocity component that u·n = 0 sets to zero: 0 for n = (±1, 0), 1 for
        (0, ±1); None for a slanted side (u·n = 0 imposed weakly, ``forms.no_penetration``)."""
        nx, ny = self.normal
        if ny == 0 and abs(nx) == 1:
            return 0
        if nx == 0 and abs(ny) == 1:
            return 1
        return None

    @property
    def slanted(self) -> bool:
        """A solid side with no penetration along no axis (not no slip, which is u = 0)."""
        return self.kind in (BoundaryKind.COULOMB, BoundaryKind.SLIP) and self.axis is None

    @property
    def has_friction(self) -> bool:
        return self.kind == BoundaryKind.COULOMB and self.friction > 0


@dataclass(frozen=True)
class Container:
    """What a model on a fixed mesh (the two-phase model) takes from a scene: the vessel
    holding the material and the light fluid, its sides, and where the material starts.

    mesh(comm, cell_size): the mesh of the vessel with cells of about ``cell_size`` (finer
    where the scene resolves a detail) and its facets tagged; boundaries: one
    :class:`Boundary` per facet tag (walls no slip or Coulomb, symmetry slip, the open top
    free_surface, an orifice outflow); fraction_region: convex CCW polygons (m, 2) whose
    union is the material at t = 0 (c = |K ∩ ∪P| / |K|); box: (length, height) when the
    vessel is the rectangle [0, length] × [0, height] (an adaptive box may remesh it), else
    None; floor: y(x) of the vessel's bottom under the side wall's strip, for the fill height
    floor + ∫ c dy there (None: not a bin); bed_layer: the convex CCW polygon of an erodible
    layer of the material on the bed (part of ``fraction_region``; the model tracks its own
    fraction c_L), None: none; front_floor: fronts count material above this height only
    (an erodible layer's 2 h_e, as the scene's ``extent``).
    """

    mesh: Callable
    boundaries: tuple[Boundary, ...]
    fraction_region: tuple[np.ndarray, ...]
    length: float
    height: float
    box: tuple[float, float] | None = None
    floor: Callable | None = None
    bed_layer: np.ndarray | None = None
    front_floor: float = 0.0

    def of_kind(self, kind: BoundaryKind) -> list[Boundary]:
        return [b for b in self.boundaries if b.kind == kind]


def box_container(length: float, height: float, boundaries: tuple[Boundary, ...],
                  region: tuple[np.ndarray, ...], **details) -> Container:
    """The rectangle [0, length] × [0, height] in structured triangles (sides tagged BED,
    LEFT, RIGHT, SURFACE: ``geometry.rectangle.structured_rectangle``); ``details`` the
    :class:`Container`'s optional fields."""
    def mesh(comm, cell_size):
        nx, ny = max(2, round(length / cell_size)), max(2, round(height / cell_size))
        return structured_rectangle(comm, length, height, nx, ny)

    return Container(mesh, boundaries, region, length, height, box=(length, height), **details)


def open_box_boundaries(bed: Boundary, left: Boundary) -> tuple[Boundary, ...]:
    """The box of a collapse: the bed, the left side x = 0, the slip right side, the open
    top (σ·n = 0: the light fluid leaves and enters freely; the pressure needs no gauge)."""
    return (bed, left, Boundary(RIGHT, "right", BoundaryKind.SLIP, (1.0, 0.0)),
            Boundary(SURFACE, "top", BoundaryKind.FREE_SURFACE))


class Scene(Protocol):
    """A scene: ``shape`` (its ``geometry.shape``), built from the config by ``from_config``."""

    shape: str

    def mesh(self, comm) -> TaggedMesh:
        """The initial mesh with its cell and facet tags, distributed over ``comm``."""

    def boundaries(self) -> tuple[Boundary, ...]:
        """One Boundary per facet tag (the order is that of the friction terms)."""

    def initial_velocity(self) -> Callable[[np.ndarray], np.ndarray]:
        """u(x, y) at t = 0, for ``Function.interpolate``."""

    def extent(self, x: np.ndarray) -> tuple[float, float]:
        """(front, maximum height) of the local nodes ``x`` (n, 3); −inf for no nodes."""

    def bed_height(self, x: np.ndarray) -> np.ndarray:
        """y = b(x) of the rigid bed under the abscissae ``x`` (0: the bed y = 0;
        ``SceneSections`` gives that)."""

    def write_msh(self, path: Path) -> Path:
        """Write the initial mesh to a gmsh ``.msh`` file (``dpcollapse mesh``)."""

    def container(self, box: tuple[float, float]) -> Container:
        """The vessel of a fixed-mesh model (:class:`Container`); ``box`` the (length,
        height) of ``model.box_length``, ``box_height`` for scenes that stand in a box.
        Only scenes whose ``models`` include two_phase provide it."""


def initial_velocity(velocity: str, height: float, surface_speed: float):
    """rest: u = 0; half_poiseuille: u = (U_s (2y/h − y²/h²), 0) along the bed y = 0."""
    h, us = height, surface_speed
    if velocity == "half_poiseuille":
        return lambda x: np.vstack([us * (2 * x[1] / h - (x[1] / h) ** 2), np.zeros(x.shape[1])])
    return lambda x: np.zeros((2, x.shape[1]))


def bed_boundary(tag: int, condition: str, mu: float) -> Boundary:
    """The bed y = 0 (n = (0, −1)): Coulomb friction μ (slip when μ = 0) or no slip."""
    if condition == "no_slip":
        return Boundary(tag, "bed", BoundaryKind.NO_SLIP, (0.0, -1.0))
    kind = BoundaryKind.COULOMB if mu > 0 else BoundaryKind.SLIP
    return Boundary(tag, "bed", kind, (0.0, -1.0), friction=mu)


def box_wall(mu_wall: float) -> Boundary:
    """The side x = 0 of a vessel against which the mass stands: Coulomb friction μ_l on p,
    as on the moving mesh, or a frictionless symmetry plane when μ_l = 0."""
    if mu_wall > 0:
        return Boundary(LEFT, "wall", BoundaryKind.COULOMB, (-1.0, 0.0), friction=mu_wall)
    return Boundary(LEFT, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0))


def walled_boundaries(bed_condition: str, mu_bed: float, mu_wall: float) -> tuple[Boundary, ...]:
    """A mass on the bed against the wall x = 0: the bed (``bed_boundary``), the wall
    (Coulomb μ_l, frictionless when μ_l = 0) and the free surface."""
    wall = BoundaryKind.COULOMB if mu_wall > 0 else BoundaryKind.SLIP
    return (bed_boundary(BED, bed_condition, mu_bed),
            Boundary(WALL, "wall", wall, (-1.0, 0.0), friction=mu_wall),
            Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE))


def top_extent(x: np.ndarray) -> tuple[float, float]:
    """Front = largest x, maximum height = largest y (slope coordinates, bed at y = 0)."""
    if not len(x):
        return -np.inf, -np.inf
    return float(x[:, 0].max()), float(x[:, 1].max())


def film_threshold(grain_diameter: float, mesh_size: float) -> float:
    """Thickness [m] below which the end of a deposit counts as a film, not the front:
    max(3 d, h/4) — a few grains (a thinner layer is not a continuum), and a fraction of the
    mesh size (a thinner layer is not resolved): ``fronts.front_thickness``, the one stated
    thickness of every model's thickness front."""
    return front_thickness(grain_diameter, mesh_size)


def vertical_thickness(points: np.ndarray, x: np.ndarray, side: int = 1) -> np.ndarray:
    r"""Total vertical thickness h(x) = ∫ 1_Ω(x, y) dy of the mass bounded by the closed
    counter-clockwise polygon ``points`` (n, 2), at each abscissa of ``x``.

    For a CCW polygon h(x) = Σ_e −sign(Δx_e) y_e(x) over the edges e that span x (edges
    running right are below the mass, edges running left above it), so an overhang counts
    its material only. ``side`` = +1 gives the right limit h(x⁺) (an edge spans x when
    x_min ≤ x < x_max), −1 the left limit h(x⁻) (x_min < x ≤ x_max).
    """
    p = np.asarray(points, dtype=float)
    a, b = p, np.roll(p, -1, axis=0)
    dx = b[:, 0] - a[:, 0]
    lo, hi = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    xs = np.asarray(x, dtype=float)[:, None]
    spans = (lo <= xs) & (xs < hi) if side > 0 else (lo < xs) & (xs <= hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(dx != 0, (xs - a[:, 0]) / np.where(dx != 0, dx, 1.0), 0.0)
    y = a[:, 1] + s * (b[:, 1] - a[:, 1])
    return np.sum(np.where(spans, -np.sign(dx) * y, 0.0), axis=1)


def thickness_front(points: np.ndarray, threshold: float) -> float:
    """The furthest x (rightwards) where the vertical thickness of the mass bounded by the
    CCW polygon ``points`` is at least ``threshold`` [m]; h(x) is linear between vertex
    abscissae, so the crossing h = threshold is exact (``fronts.profile_front``'s definition
    on the polygon's exact profile, steps included). −inf when the mass is nowhere that
    thick."""
    xs = np.unique(np.asarray(points, dtype=float)[:, 0])
    right = vertical_thickness(points, xs, +1)   # h just right of each vertex abscissa
    left = vertical_thickness(points, xs, -1)    # h just left of it
    for k in range(len(xs) - 1, -1, -1):        # from the right: interval (xs[k], xs[k+1]),
        if k + 1 < len(xs) and right[k] >= threshold:  # then the point xs[k]
            h0, h1 = right[k], left[k + 1]       # h falls through the threshold inside
            return float(xs[k] + (h0 - threshold) / (h0 - h1) * (xs[k + 1] - xs[k]))
        if left[k] >= threshold:                 # thick up to xs[k] (a step down there)
            return float(xs[k])
    return -np.inf


@dataclass(frozen=True)
class SceneSections:
    """A scene that holds its config sections instead of copying their keys: ``geometry``
    (its class of ``config.geometry``, e.g. ``ColumnGeometry``), ``boundary``
    (``config.numerics.BoundaryConfig``: the bed condition, μ_b, μ_l) and ``initial``
    (``config.run.InitialConfig``: the initial velocity). A scene is built from the config by
    ``from_config`` and reads every length, angle and friction from these sections."""

    geometry: object
    boundary: object
    initial: object

    @classmethod
    def from_config(cls, cfg):
        return cls(cfg.geometry, cfg.boundary, cfg.initial)

    @property
    def mesh_size(self) -> float:
        return self.geometry.mesh_size

    def bed_height(self, x: np.ndarray) -> np.ndarray:
        """y = b(x) of the rigid bed under the abscissae ``x`` [m]: 0, the bed y = 0 (a scene
        whose bed has a step overrides it; the moving mesh lands nodes on it and lets bed nodes
        that pass the end of a higher bed take off, ``ale.motion``)."""
        return np.zeros_like(np.asarray(x, dtype=float))

    def bed(self) -> Boundary:
        """The bed y = 0 of ``boundary.bed_condition`` (``bed_boundary``)."""
        return bed_boundary(BED, self.boundary.bed_condition, self.boundary.mu_bed)


class PolygonScene(SceneSections):
    """Mesh and .msh output of a scene that is one tagged polygon (``polygon()`` on rank 0),
    or the gmsh file ``geometry.mesh_file`` when one is given (cells of
    ``geometry.mesh_size``, ``geometry.surface_mesh_size`` on the free surface)."""

    @property
    def surface_mesh_size(self) -> float | None:
        return self.geometry.surface_mesh_size

    @property
    def mesh_file(self) -> Path | None:
        return self.geometry.mesh_file

    def mesh(self, comm) -> TaggedMesh:
        if self.mesh_file:
            return read_msh(comm, self.mesh_file)
        points, tags = self.polygon() if comm.rank == 0 else (None, None)
        return mesh_polygon(comm, points, tags, self.mesh_size, self.surface_mesh_size)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        points, tags = self.polygon()
        write_polygon_msh(path, points, tags, self.mesh_size, self.surface_mesh_size)
        return path
