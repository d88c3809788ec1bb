"""The interface-adaptive mesh of the two-phase box (``model.min_cell`` < ``model.max_cell``):
fine cells in the granular phase and a band around it, coarse cells in the light fluid far
from it, graded in between; rebuilt as the granular phase moves.

The size field: with d(x) the distance from x to the nearest centroid of a granular cell
(c > ``model.refine_fraction``) of the current mesh, b = ``model.refine_band`` × h_min the
band and g = ``model.refine_grading``::

    h(x) = h_min                                  for d ≤ b
    h(x) = min(h_max, h_min + g (d − b))          beyond

The thin layers' second level (``model.layer_cell`` = h_l < h_min, issue 50: a tongue on
the bed thinner than a cell, which c can carry only as a partly filled row of cells): the
box's strips S_j = [j Δ, (j + 1) Δ] × ℝ of the width Δ = h_min carry the grain column's
thickness h_j = (1/Δ) Σ_{K: centroid in S_j} c_K |K|; a granular cell of a strip with
h_j < k h_min (k = ``model.thin_layer_cells``) is a thin layer's, and with d_l(x) the distance
to the nearest of those centroids and b_l = ``model.refine_band`` × h_l::

    h(x) = min(h_above(x), h_l + g max(d_l − b_l, 0))

(h_above the formula above): cells of h_l across and along the thin layer and its band,
graded back to h_min. Where the column is thicker (the body of the deposit) the size field
is unchanged.

gmsh meshes the box [0, L] × [0, H] (Frontal-Delaunay) with h as its background field, read
from a structured background grid of spacing min(h_max, 2 h_min, 4 h_l) (a list-based post-processing
view, the ``PostView`` field). The sides are tagged as the uniform box
(``models.two_phase.adapter.box_mesh``).

``AdaptiveBox`` is the domain the loop asks (``domain.base.Domain``): it never moves; it asks
for a remesh when a granular cell is coarser than ``REFINED`` × h_min (the phase reached the
graded zone: the band is b − the distance the phase moved since the last rebuild) or every
``model.remesh_every`` steps (0: only then), and with ``model.layer_cell`` also when a thin
layer's granular cell is coarser than ``REFINED`` × h_l. The loop (``simulation._remesh``) carries u and p
by interpolation and c (and c_L) by the exact conservative remap
(``models.two_phase.remap``).
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from dpcollapse import compat
from dpcollapse.ale.quality import signed_areas
from dpcollapse.domain.fixed import FixedDomain
from dpcollapse.geometry.mesher import (
    BED,
    DOMAIN,
    LEFT,
    RIGHT,
    SURFACE,
    TAG_NAMES,
    TaggedMesh,
    generate_bounded,
    gmsh_session,
)
from dpcollapse.geometry.regions import cell_triangles as owned_triangles

#: a granular cell larger than this many h_min (equilateral side of its area) triggers a remesh
REFINED = 1.5


def equivalent_size(triangles: np.ndarray) -> np.ndarray:
    """The side of the equilateral triangle of each triangle's area [m]."""
    return np.sqrt(4.0 * (0.5 * np.abs(signed_areas(triangles))) / math.sqrt(3.0))


def _graded(points: np.ndarray, seeds: np.ndarray, fine: float, coarse: float, band: float,
            grading: float) -> np.ndarray:
    """min(coarse, fine + g max(d − band, 0)) at ``points`` (n, 2), d the distance to the
    nearest of ``seeds`` (m ≥ 1, 2)."""
    # each distinct point once (the background grid repeats its vertices), and no search
    # beyond the distance where h reaches coarse (cKDTree returns inf there); the pairs
    # (x, y) compared as complex numbers: the same points as np.unique(axis=0) sorted the
    # same way, 6× faster (2026-12-07-adaptive-column-speed.md)
    pairs = np.ascontiguousarray(points, dtype=float).view(np.complex128).ravel()
    unique, inverse = np.unique(pairs, return_inverse=True)
    unique = unique.view(np.float64).reshape(-1, 2)
    reach = band + (coarse - fine) / grading
    d, _ = cKDTree(seeds).query(unique, distance_upper_bound=reach * (1 + 1e-9))
    h = np.minimum(coarse, fine + grading * np.maximum(d - band, 0.0))
    return h[inverse.reshape(-1)]


class SizeField:
    """h(x) from the centroids of the granular cells and of the thin layers' granular cells
    (the module's formulas; ``layer_cell`` None: no second level)."""

    def __init__(self, min_cell: float, max_cell: float, band: float, grading: float,
                 layer_cell: float | None = None, thin_cells: float = 2.0):
        self.min_cell, self.max_cell, self.band, self.grading = min_cell, max_cell, band, grading
        self.layer_cell, self.thin_cells = layer_cell, thin_cells
        # the thin layers' band: refine_band layer cells (band / min_cell of them)
        self.layer_band = band * layer_cell / min_cell if layer_cell else 0.0

    def __call__(self, points: np.ndarray, granular: np.ndarray,
                 thin: np.ndarray | None = None) -> np.ndarray:
        """h at ``points`` (n, 2) for granular cell centroids ``granular`` (m, 2) and the thin
        layers' ones ``thin`` (k, 2; used with ``layer_cell``)."""
        if len(granular) == 0:
            return np.full(len(points), self.max_cell)
        h = _graded(points, granular, self.min_cell, self.max_cell, self.band, self.grading)
        if self.layer_cell and thin is not None and len(thin):
            h = np.minimum(h, _graded(points, thin, self.layer_cell, self.max_cell,
                                      self.layer_band, self.grading))
        return h


def thin_layer_cells(triangles: np.ndarray, c: np.ndarray, threshold: float, width: float,
                     thin_height: float, comm=None) -> np.ndarray:
    """Which of the cells (n, 3, 2) with fractions ``c`` (n,) are granular (c > ``threshold``)
    cells of a thin layer: their strip's column h_j = (1/width) Σ c_K |K| (the cells of
    centroid in S_j = [j width, (j + 1) width] × ℝ, summed over ``comm``'s ranks) below
    ``thin_height``."""
    centre = triangles[:, :, 0].mean(axis=1) if len(triangles) else np.zeros(0)
    strip = np.floor(centre / width).astype(int)
    count = int(max(strip.max(initial=-1) + 1, 1))
    if comm is not None:
        count = comm.allreduce(count, op=MPI.MAX)
    area = 0.5 * np.abs(signed_areas(triangles)) if len(triangles) else np.zeros(0)
    column = np.bincount(strip, weights=c * area, minlength=count) / width
    if comm is not None:
        column = comm.allreduce(column, op=MPI.SUM)
    return (c > threshold) & (column[strip] < thin_height)


def background_grid(length: float, height: float, spacing: float) -> np.ndarray:
    """Structured triangles (n, 3, 2) of [0, length] × [0, height] of about ``spacing``."""
    nx, ny = max(1, round(length / spacing)), max(1, round(height / spacing))
    x, y = np.meshgrid(np.linspace(0, length, nx + 1), np.linspace(0, height, ny + 1))
    p = np.stack([x, y], axis=-1)
    a, b, c, d = p[:-1, :-1], p[:-1, 1:], p[1:, 1:], p[1:, :-1]
    return np.concatenate([np.stack([a, b, c], axis=-2).reshape(-1, 3, 2),
                           np.stack([a, c, d], axis=-2).reshape(-1, 3, 2)])


def _build_box_model(gmsh, length: float, height: float, grid: np.ndarray, sizes: np.ndarray,
                     max_cell: float) -> None:
    """The box in gmsh with its sides' physical tags and the background size view."""
    gmsh.model.add("box")
    geo = gmsh.model.geo
    corners = [geo.addPoint(x, y, 0.0, max_cell)
               for x, y in ((0, 0), (length, 0), (length, height), (0, height))]
    lines = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    geo.synchronize()
    for line, tag in zip(lines, (BED, RIGHT, SURFACE, LEFT)):
        gmsh.model.addPhysicalGroup(1, [line], tag)
        gmsh.model.setPhysicalName(1, tag, TAG_NAMES[tag])
    gmsh.model.addPhysicalGroup(2, [surface], DOMAIN)
    view = gmsh.view.add("size")
    n = len(grid)
    # "ST": per triangle x1 x2 x3 y1 y2 y3 z1 z2 z3 v1 v2 v3
    data = np.concatenate([grid[:, :, 0], grid[:, :, 1], np.zeros((n, 3)), sizes], axis=1)
    gmsh.view.addListData(view, "ST", n, data.ravel().tolist())
    field = gmsh.model.mesh.field.add("PostView")
    gmsh.model.mesh.field.setNumber(field, "ViewTag", view)
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)


def adaptive_box(comm, length: float, height: float, size: SizeField,
                 granular: np.ndarray, thin: np.ndarray | None = None) -> TaggedMesh:
    """The box meshed by gmsh on rank 0 with the size field ``size`` of the granular cell
    centroids ``granular`` and the thin layers' ``thin`` (every rank holds them),
    distributed over ``comm``."""
    if comm.rank == 0:
        spacing = min(size.max_cell, 2.0 * size.min_cell)
        if size.layer_cell:     # the thin layers' band (4 h_l) spans a background triangle
            spacing = min(spacing, 4.0 * size.layer_cell)
        grid = background_grid(length, height, spacing)
        sizes = size(grid.reshape(-1, 2), granular, thin).reshape(-1, 3)
        with gmsh_session() as gmsh:
            generate_bounded(gmsh, lambda g: _build_box_model(g, length, height, grid, sizes,
                                                             size.max_cell))  # exit 4, no hang
            mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim=2)
    else:
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(None, comm, 0, gdim=2)
    mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
    return TaggedMesh(mesh, facet_tags, cell_tags)


def granular_centroids(fraction, threshold: float) -> np.ndarray:
    """The centroids of the cells with c > ``threshold`` of every rank, on every rank."""
    tri = owned_triangles(fraction.mesh)
    own = tri[fraction.owned_values() > threshold].mean(axis=1)
    return np.concatenate(fraction.comm.allgather(own)).reshape(-1, 2)


def _thin_mask(fraction, size: SizeField, threshold: float) -> np.ndarray:
    """The owned cells of ``fraction`` that are a thin layer's granular cells
    (``thin_layer_cells`` on strips of h_min, thin below ``size.thin_cells`` h_min)."""
    return thin_layer_cells(owned_triangles(fraction.mesh), fraction.owned_values(), threshold,
                            size.min_cell, size.thin_cells * size.min_cell, fraction.comm)


def thin_centroids(fraction, size: SizeField, threshold: float,
                   mask: np.ndarray | None = None) -> np.ndarray | None:
    """The centroids of the thin layers' granular cells of every rank, on every rank (None
    without ``size.layer_cell``); ``mask``: those owned cells when already known."""
    if not size.layer_cell:
        return None
    if mask is None:
        mask = _thin_mask(fraction, size, threshold)
    own = owned_triangles(fraction.mesh)[mask].mean(axis=1)
    return np.concatenate(fraction.comm.allgather(own)).reshape(-1, 2)


class AdaptiveBox(FixedDomain):
    """The fixed box whose mesh follows the granular phase (``domain.base.Domain``): nothing
    moves (``FixedDomain``'s step limit, move, undo and recompute), the mesh is rebuilt."""

    def __init__(self, length: float, height: float, size: SizeField, threshold: float,
                 every: int):
        super().__init__()
        self.length, self.height, self.size = length, height, size
        self.threshold, self.every = threshold, every
        self._centroids = self._thin = None

    def mesh_for(self, comm, fraction) -> TaggedMesh:
        """A new mesh refined around the granular cells of ``fraction`` (c > threshold) and,
        with ``layer_cell``, further around its thin layers."""
        return adaptive_box(comm, self.length, self.height, self.size,
                            granular_centroids(fraction, self.threshold),
                            thin_centroids(fraction, self.size, self.threshold))

    def needs_remesh(self, disc, state) -> str | None:
        """A granular cell coarser than REFINED h_min (a thin layer's: REFINED h_l), or
        ``every`` steps since the last."""
        fraction = disc.fraction
        tri = owned_triangles(fraction.mesh)
        granular = fraction.owned_values() > self.threshold
        coarse = bool(np.any(equivalent_size(tri[granular]) > REFINED * self.size.min_cell))
        thin = None
        if self.size.layer_cell:
            thin = _thin_mask(fraction, self.size, self.threshold)
            coarse = coarse or bool(np.any(equivalent_size(tri[thin]) > REFINED * self.size.layer_cell))
        coarse = fraction.comm.allreduce(coarse, op=MPI.LOR)
        since = state.step - max(state.last_remesh_step, 0)
        reason = None
        if coarse and state.step > state.last_remesh_step:
            reason = "granular phase left the fine band"
        elif self.every and since >= self.every:
            reason = f"{self.every} steps"
        if reason:
            self._centroids = granular_centroids(fraction, self.threshold)
            self._thin = thin_centroids(fraction, self.size, self.threshold, thin)
        return reason

    def remesh(self, tagged, area0: float):
        """The box refined around the granular cells found by ``needs_remesh``:
        (tagged mesh, 4 corners)."""
        comm = tagged.mesh.comm
        return adaptive_box(comm, self.length, self.height, self.size, self._centroids,
                            self._thin), 4
