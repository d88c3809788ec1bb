"""Remeshing: rebuild the domain from its current boundary and carry (u, p) across.

1. Gather the tagged boundary edges of every rank on rank 0 and chain them into one
   polygon (``geometry.polygon``), with the holes a surgery kept. With ``surgery``, a free
   surface that touches the bed or the mass itself is first rebuilt as the union of the mass
   (``geometry.surgery``: pockets kept as holes or closed). Otherwise (surgery off) a free
   surface folded over itself (a crossing) is untangled first: the smaller loop at each
   crossing is cut off at the crossing point (``polygon.untangle``; its area is the area
   change reported). Every existing boundary vertex stays where it is or is dropped; none
   is moved or snapped, so the toe (the bed/free-surface corner) and the front position
   are exactly continuous. Long edges are split on the edge (no area change); clustered
   vertices are dropped only while the total area change stays below a bound
   (``max_area_change``).
2. Mesh the polygon with gmsh on rank 0 (``geometry.mesher``), distribute.
3. The model carries its fields across (``models.stokes.state``: ``snapshot`` cell by
   cell, ``transfer`` to the new mesh's dofs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse import parallel
from dpcollapse.geometry.boundary_loops import BoundaryLoops
from dpcollapse.geometry.film_face import cut_at_repose
from dpcollapse.geometry.mesher import BED, SURFACE, TaggedMesh, boundary_edges, mesh_polygon
from dpcollapse.geometry.polygon import (
    BoundaryPolygon,
    chain_boundary,
    chain_loops,
    clip_right,
    offset_run,
    polygon_is_simple,
    remove_spikes,
    resample,
    signed_area,
    signed_volume,
    untangle,
    where_it_crosses,
)
from dpcollapse.geometry.surgery import Surgery, close_small_holes, operate, surgery_needed
from dpcollapse.scenes.base import thickness_front


@dataclass
class RemeshReport:
    area_before: float
    area_after: float
    cells_before: int
    cells_after: int
    boundary_vertices: int
    outside_distance: float


#: With a film trim, free-surface vertices with an interior angle below this [deg] (hairpin
#: spikes) are dropped at remeshes.
SPIKE_ANGLE = 15.0


@dataclass
class _Repaired:
    polygon: BoundaryPolygon
    area_before: float      # signed area of the boundary as it was (folds included)


def boundary_polygon(tagged: TaggedMesh, trim_thickness: float = 0.0) -> _Repaired | None:
    """The tagged boundary polygon of the (distributed) mesh, on rank 0 (None elsewhere),
    repaired (``repair_polygon``), with the signed area of the boundary before repair."""
    all_edges, all_tags = boundary_edges(tagged)
    if tagged.mesh.comm.rank != 0:
        return None
    return _repaired(all_edges, all_tags, trim_thickness)


def _repaired(all_edges, all_tags, trim_thickness: float) -> _Repaired:
    folded = chain_boundary(all_edges, all_tags, simple=False)
    return _Repaired(repair_polygon(folded, trim_thickness), folded.area)


def repair_polygon(poly: BoundaryPolygon, trim_thickness: float = 0.0,
                   face_slope: float | None = None) -> BoundaryPolygon:
    """With ``trim_thickness`` > 0: untangle a folded free surface (``polygon.untangle``),
    drop hairpin spikes of the surface (``polygon.remove_spikes``), put the underside
    of a nose closer to the bed than it on the bed (one run of vertices from the bed,
    ``_landing_underside``) and cut off the film ahead of the last
    point x_f where the mass is at least that thick
    (``scenes.base.thickness_front``) by the vertical x = x_f (tagged free surface; the
    cut face, δ high, slumps a little after each trim), or with ``face_slope`` = μ_r > 0
    by a face of that slope from δ above the mass's foot at x_f down to the bed
    (``geometry.film_face.cut_at_repose``: a face at the angle of repose, which does not
    slump; the vertical cut where it cannot be made). A trim that would leave a non-simple
    polygon (the mass crossing x = x_f several times) is skipped."""
    if trim_thickness <= 0:
        # no repair asked for: a surface folded through itself ends the run (exit 4, where)
        if not polygon_is_simple(poly.points):
            raise ValueError("boundary loop intersects itself"
                             + where_it_crosses(poly.points, poly.edge_tags))
        points, tags = poly.points, poly.edge_tags
    else:
        points, tags, _ = untangle(poly.points, poly.edge_tags, poly.corners)
    if trim_thickness > 0:
        # hairpin spikes of a crumpled surface (no crossing): a 0° angle in the new mesh
        points, tags = remove_spikes(points, tags, SURFACE, SPIKE_ANGLE)
        # the underside of a nose closer to the bed than trim_thickness lands on it
        close = _landing_underside(points, tags, trim_thickness)
        if close.any():
            snapped = points.copy()
            snapped[close, 1] = 0.0
            if polygon_is_simple(snapped):
                points = snapped
    # free-surface edges lying on the bed y = 0 (a landed nose) become bed
    on_bed = (points[:, 1] == 0.0) & (np.roll(points[:, 1], -1) == 0.0)
    tags = np.where((tags == SURFACE) & on_bed, BED, tags)
    if trim_thickness > 0:
        x_cut = thickness_front(points, trim_thickness)
        xmin, xmax = points[:, 0].min(), points[:, 0].max()
        if xmin < x_cut < xmax:
            cut = None
            if face_slope is not None and face_slope > 0:
                cut = cut_at_repose(points, tags, x_cut, trim_thickness, face_slope, SURFACE)
                if cut is not None and not (len(cut[0]) >= 3 and polygon_is_simple(cut[0])):
                    cut = None
            if cut is None:
                cut = clip_right(points, tags, x_cut, SURFACE)
            if len(cut[0]) >= 3 and polygon_is_simple(cut[0]):
                points, tags = cut
    return BoundaryPolygon(points, tags)


def _landing_underside(points: np.ndarray, tags: np.ndarray, thickness: float) -> np.ndarray:
    """The vertices of a nose's underside that land (mask): from each vertex on the bed
    y = 0, the free-surface vertices that follow it in a row with both edges running right
    (CCW: the mass above them) and lower than ``thickness``. One run from the bed, not every
    such vertex alone: on a near-vertical front face whose vertices' x wander by micrometres,
    single vertices put on the bed made a spike as high as the face (issue 49, a = 10 at
    ΔX = 5 mm: 4.8 mm high, 31 µm wide, a sub-cell lip on which the fixed point stalled)."""
    e = np.roll(points, -1, axis=0) - points
    down = (e[:, 0] > 0) & (tags == SURFACE)        # CCW: an edge running right has
    under = down & np.roll(down, 1)                  # the mass above it
    close = under & (points[:, 1] > 0) & (points[:, 1] < thickness)
    land = np.zeros(len(points), dtype=bool)
    n = len(points)
    for i in np.flatnonzero(close & (np.roll(points[:, 1], 1) == 0.0)):   # a run's first vertex
        while close[i] and not land[i]:
            land[i] = True
            i = (i + 1) % n
    return land


def remesh_domain(tagged: TaggedMesh, mesh_size: float, surface_mesh_size: float | None,
                  max_area_change: float, trim_thickness: float = 0.0,
                  conserve_area: bool = False, surgery: bool = False,
                  surgeries: list | None = None,
                  axisymmetric: bool = False,
                  trim_face_slope: float | None = None,
                  background=None) -> tuple[TaggedMesh, float, int]:
    """A new mesh of the current domain; returns (mesh, polygon area change, #vertices).
    ``background``: the size inside from a size field (``geometry.mesher.build_polygon_model``;
    ``ale.size_field``), the boundary resampled as without it.

    ``trim_thickness`` [m] > 0 trims a front film thinner than it (``repair_polygon``), by a
    face of slope ``trim_face_slope`` (None: vertical);
    ``conserve_area`` puts back the area that surgery, untangling, trimming and resampling
    changed by moving the free surface's interior vertices along their normal by one distance
    (``polygon.offset_run``; of order ΔA / surface length). ``surgery``: contacts of the
    free surface with the bed or the mass are operated on first (``geometry.surgery``); each
    surgery done is appended to ``surgeries`` (every rank gets it). ``axisymmetric``: the
    measure put back and returned is the volume of the body of revolution about x = 0,
    2π∫∫ x dA (``polygon.signed_volume``), instead of the area."""
    comm = tagged.mesh.comm
    all_edges, all_tags = boundary_edges(tagged)
    measure = signed_volume if axisymmetric else signed_area

    def new_boundary():       # rank 0; its failure (a ValueError) is every rank's
        loops = chain_loops(all_edges, all_tags)
        outer, holes = loops[0], loops[1:]
        area_before = measure(outer.points) - sum(abs(measure(h.points)) for h in holes)
        done = operate(outer, mesh_size, holes) if surgery else None
        if done is not None:
            outer, holes = done.outer, done.holes
        holes, closed = close_small_holes(holes, mesh_size)
        if closed and done is None:
            done = Surgery(outer, holes, area_before, area_before + sum(closed),
                           closed_pockets=closed)
        elif closed:
            done.closed_pockets += closed
            done.holes, done.area_after = holes, done.area_after + sum(closed)
        hs = surface_mesh_size or mesh_size

        def target(tag: int) -> float:
            return hs if tag == SURFACE else mesh_size

        poly, _ = resample(repair_polygon(outer, trim_thickness, trim_face_slope), target,
                           max_area_change)
        holes = [resample(h, target, max_area_change)[0] for h in holes]
        hole_area = sum(abs(measure(h.points)) for h in holes)
        points, tags = poly.points, poly.edge_tags
        if conserve_area:
            # vertices on the bed y = 0 (a landed nose's underside) stay on it
            moved = offset_run(points, tags, SURFACE, area_before + hole_area - measure(points),
                               movable=points[:, 1] > 0, measure=measure)
            if polygon_is_simple(moved):
                points = moved
        area_after = measure(points) - hole_area
        hole_loops = [(h.points, h.edge_tags) for h in holes]
        return points, tags, hole_loops, area_after - area_before, done

    points, tags, holes, d_area, done = parallel.on_root(comm, new_boundary)   # on every rank
    if done is not None and surgeries is not None:
        surgeries.append(done)
    nverts = len(points) + sum(len(h[0]) for h in holes)
    size = None if background is None else _field_sizes(
        background, [points] + [h[0] for h in holes], mesh_size, surface_mesh_size)
    return (mesh_polygon(comm, points, tags, mesh_size, surface_mesh_size, size=size,
                         holes=holes, background=background),
            d_area, nverts)


def _field_sizes(background, loops: list, mesh_size: float, surface_mesh_size: float | None):
    """size(point, tag) at the boundary's vertices with a size field: the smaller of the
    tag's size and the field's there (an edge longer than 1.5 of it is split by gmsh)."""
    from dpcollapse.ale.size_field import SizeField

    pts = np.concatenate([np.asarray(p, dtype=float) for p in loops])
    local = dict(zip(map(tuple, pts), SizeField(*background).at(pts)))
    hs = surface_mesh_size or mesh_size

    def size(point: np.ndarray, tag: int) -> float:
        return min(hs if tag == SURFACE else mesh_size, float(local[tuple(point)]))

    return size


def boundary_contact(tagged: TaggedMesh, mesh_size: float,
                     chained: BoundaryLoops | None = None) -> str | None:
    """The contacts of the free surface with the bed or the mass that a surgery would act on
    now (``geometry.surgery.surgery_needed``: "crossing", "self-contact", "bed contact", "notch"), or
    None; the same on every rank. ``chained`` (``geometry.boundary_loops``) reuses the
    chaining of the boundary edges while the mesh only moves (the same loops)."""
    all_edges, all_tags = boundary_edges(tagged)

    def kinds():
        if chained is None:
            loops = chain_loops(all_edges, all_tags)
        else:
            loops = chained.loops(all_edges, all_tags, (tagged.mesh, tagged.facet_tags))
        return surgery_needed(loops[0], mesh_size, loops[1:])

    return parallel.on_root(tagged.mesh.comm, kinds)
