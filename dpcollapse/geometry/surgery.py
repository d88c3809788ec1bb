"""Boundary surgery at remeshing: a free surface that folds onto the bed or onto the mass
itself is rebuilt as the union of what the mass occupies (polygon booleans of shapely ≥ 2).

A *contact* is one of
- a crossing: two boundary edges share a point (the mesh moved a nose through the surface);
- a near contact: a free-surface vertex p and a boundary edge e with dist(p, e) < g,
  g = CONTACT_GAP·h, the segment between them through air (its midpoint outside the mass)
  and p at least CONTACT_ARC·h from e along the boundary (not a neighbour);
- a bed contact: a landed nose tip, a free-surface vertex on the bed y = 0 between two
  free-surface edges (the mesh motion lands nodes exactly on the bed: no gap needed).

The surgery (``operate``) then builds, with M the region of nonzero winding number of the
boundary loop minus the existing holes (a folded loop's doubly covered part counts once),
B = the bed solid y ≤ 0 (when the boundary has bed edges) and T the bridge triangles
of each near contact: the convex hull of p, of q its closest point on e and of the points
at distance g from p along its two edges and from q along e (so that it overlaps the mass,
not only touches it):

    U = M ∪ T ∪ B,    each interior ring R of U (a pocket of light fluid enclosed by the
                      mass, or by the mass and the bed): |R| < CLOSE_CELLS·(√3/4)h²
                      → closed (U ∪ R), else kept as a hole (stress-free surface);
    new mass = U \\ B.

Nothing of the mass is dropped (a mass that would split into pieces is an error, not a
cut). Edges of the new boundary on y = 0 are bed; edges lying on an old edge keep its tag;
the rest (bridges, crossing points) are free surface. The area change |new| − |old| (bridges
and closed pockets add, a crossing's overlap removes) is returned for the caller to report.
A landed tip whose pocket is kept changes nothing (no surgery).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dpcollapse.geometry.mesher import BED, SURFACE
from dpcollapse.geometry.polygon import BoundaryPolygon, _orient, _signed_area, polygon_is_simple

#: Near contact when two boundary pieces are closer than this fraction of the mesh size h.
CONTACT_GAP = 0.25
#: ... and at least this many h apart along the boundary.
CONTACT_ARC = 4.0
#: Pockets smaller than this many equilateral cells of side h are closed (a pocket that
#: cannot be meshed around with cells of size h), larger ones kept.
CLOSE_CELLS = 1.0


@dataclass
class Surgery:
    """The rebuilt boundary: the outer loop (CCW), the holes (CCW point order, every edge
    free surface), what was done and the area change [m²]."""

    outer: BoundaryPolygon
    holes: list[BoundaryPolygon]
    area_before: float
    area_after: float
    crossings: bool = False
    near_contacts: int = 0
    bed_contacts: int = 0
    closed_pockets: list[float] = field(default_factory=list)   # their areas [m²]
    kept_pockets: list[float] = field(default_factory=list)
    #: on a two-region mesh (``geometry.region_surgery``), per region name: its area before
    #: [m²], the surgery's change and the change after the remesh (put back or not) [m²]
    regions: dict = field(default_factory=dict)

    @property
    def area_change(self) -> float:
        return self.area_after - self.area_before

    def describe(self) -> str:
        what = []
        if self.crossings:
            what.append("crossing")
        if self.near_contacts:
            what.append(f"{self.near_contacts} self-contact(s)")
        if self.bed_contacts:
            what.append(f"{self.bed_contacts} bed contact(s)")
        pockets = (f"{len(self.closed_pockets)} pocket(s) closed "
                   f"({sum(self.closed_pockets):.2e} m²), {len(self.kept_pockets)} kept as holes")
        return f"{', '.join(what)}; {pockets}; area {self.area_change:+.2e} m²"


def loop_area(poly: BoundaryPolygon, holes: list[BoundaryPolygon] = ()) -> float:
    """The mass's area: the outer loop's signed area minus its holes' |area|."""
    return poly.area - sum(abs(h.area) for h in holes)


def _arc_positions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    lengths = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    s = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    return s, lengths, float(lengths.sum())


def _winding(points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Winding number of the closed loop ``points`` around each query point q (m, 2)."""
    a = points[None, :, :]
    b = np.roll(points, -1, axis=0)[None, :, :]
    q = np.asarray(q, dtype=float).reshape(-1, 2)[:, None, :]
    up = (a[..., 1] <= q[..., 1]) & (b[..., 1] > q[..., 1])
    down = (a[..., 1] > q[..., 1]) & (b[..., 1] <= q[..., 1])
    side = _orient(a, b, q)
    return (np.sum(up & (side > 0), axis=1) - np.sum(down & (side < 0), axis=1)).astype(int)


def near_contacts(points: np.ndarray, tags: np.ndarray, mesh_size: float
                  ) -> list[tuple[int, int, np.ndarray]]:
    """Near self-contacts (module docstring): (vertex k, edge j, closest point on j), one per
    vertex (its closest edge), free-surface vertices only."""
    p = np.asarray(points, dtype=float)
    gap, min_arc = CONTACT_GAP * mesh_size, CONTACT_ARC * mesh_size
    a, b = p, np.roll(p, -1, axis=0)
    surface_vertex = (tags == SURFACE) | (np.roll(tags, 1) == SURFACE)
    ks = np.flatnonzero(surface_vertex)
    if not ks.size:
        return []
    e = b - a
    len2 = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    t = np.clip(np.einsum("kjd,jd->kj", p[ks, None, :] - a[None], e) / len2, 0.0, 1.0)
    closest = a[None] + t[..., None] * e[None]
    dist = np.linalg.norm(closest - p[ks, None, :], axis=2)
    s, lengths, perimeter = _arc_positions(p)
    along = np.abs(s[None, :] + t * lengths[None, :] - s[ks, None])
    arc = np.minimum(along, perimeter - along)
    candidate = (dist < gap) & (arc >= min_arc) & (dist > 0)
    out = []
    for row in np.flatnonzero(candidate.any(axis=1)):
        cols = np.flatnonzero(candidate[row])
        j = int(cols[np.argmin(dist[row, cols])])
        q = closest[row, j]
        mid = 0.5 * (p[ks[row]] + q)
        if _winding(p, mid)[0] == 0:          # air between them
            out.append((int(ks[row]), j, q))
    return out


def bed_contacts(points: np.ndarray, tags: np.ndarray) -> list[int]:
    """Landed nose tips: free-surface vertices on the bed y = 0 (the mesh motion puts a
    landing node exactly there) whose two edges are free surface — between the toe and such
    a vertex the mass and the bed enclose a pocket."""
    p = np.asarray(points, dtype=float)
    if not np.any((tags == BED) & (p[:, 1] == 0.0) & (np.roll(p[:, 1], -1) == 0.0)):
        return []       # no bed at y = 0
    surface_vertex = (tags == SURFACE) & (np.roll(tags, 1) == SURFACE)
    return [int(k) for k in np.flatnonzero(surface_vertex & (p[:, 1] == 0.0))]


def contact_kinds(poly: BoundaryPolygon, mesh_size: float,
                  holes: list[BoundaryPolygon] = ()) -> list[str]:
    """Which contacts (module docstring) the boundary has: "crossing", "self-contact",
    "bed contact"; empty when none."""
    pts, tags = np.asarray(poly.points), np.asarray(poly.edge_tags)
    found = []
    if not polygon_is_simple(pts) or any(not polygon_is_simple(h.points) for h in holes):
        found.append("crossing")
    if near_contacts(pts, tags, mesh_size):
        found.append("self-contact")
    if bed_contacts(pts, tags):
        found.append("bed contact")
    return found


def surgery_needed(poly: BoundaryPolygon, mesh_size: float,
                   holes: list[BoundaryPolygon] = ()) -> str | None:
    """The contacts (``contact_kinds``, joined) when a surgery would change the boundary,
    else None: a landed tip whose pocket is kept asks for nothing (a remesh every few steps
    would not change it). A union that would come apart counts as needed (the remesh then
    reports it)."""
    kinds = contact_kinds(poly, mesh_size, holes)
    if kinds == ["bed contact"]:
        try:
            if operate(poly, mesh_size, holes) is None:
                return None
        except ValueError:
            pass
    return ", ".join(kinds) if kinds else None


def close_area(mesh_size: float) -> float:
    """Pockets smaller than this [m²] are closed: CLOSE_CELLS equilateral cells of side h."""
    return CLOSE_CELLS * math.sqrt(3) / 4 * mesh_size ** 2


def close_small_holes(holes: list[BoundaryPolygon], mesh_size: float
                      ) -> tuple[list[BoundaryPolygon], list[float]]:
    """The holes kept (area ≥ ``close_area``) and the areas of those closed (a pocket that
    shrank below it since a surgery kept it)."""
    kept = [h for h in holes if abs(h.area) >= close_area(mesh_size)]
    return kept, [abs(h.area) for h in holes if abs(h.area) < close_area(mesh_size)]


def _region(points: np.ndarray):
    """The region of nonzero winding number of a closed (possibly self-crossing) loop, as a
    shapely geometry: the union of the faces of its noded linework that it winds around."""
    import shapely
    from shapely.geometry import LinearRing

    ring = LinearRing(points)
    faces = list(shapely.polygonize([shapely.node(ring)]).geoms)
    if not faces:
        return shapely.Polygon()
    reps = np.array([f.representative_point().coords[0] for f in faces])
    keep = [f for f, w in zip(faces, _winding(points, reps)) if w != 0]
    return shapely.union_all(keep)


def _snap_bed(points: np.ndarray, scale: float) -> np.ndarray:
    pts = np.array(points, dtype=float)
    pts[np.abs(pts[:, 1]) <= 1e-12 * scale, 1] = 0.0
    return pts


def _retag(points: np.ndarray, old_points: np.ndarray, old_tags: np.ndarray, has_bed: bool,
           scale: float) -> np.ndarray:
    """Tags of the edges of a new loop: on y = 0 bed (with a bed), on an old edge its tag,
    otherwise free surface."""
    a, b = points, np.roll(points, -1, axis=0)
    oa, ob = old_points, np.roll(old_points, -1, axis=0)
    e = ob - oa
    len2 = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    tags = np.full(len(points), SURFACE, dtype=np.int64)
    tol = 1e-9 * scale

    def dist(q):   # (n, m): from each q to each old edge
        t = np.clip(np.einsum("kjd,jd->kj", q[:, None, :] - oa[None], e) / len2, 0.0, 1.0)
        return np.linalg.norm(oa[None] + t[..., None] * e[None] - q[:, None, :], axis=2)

    on = (dist(a) <= tol) & (dist(b) <= tol) & (dist(0.5 * (a + b)) <= tol)
    some = on.any(axis=1)
    tags[some] = old_tags[np.argmax(on[some], axis=1)]
    if has_bed:
        tags[(a[:, 1] == 0.0) & (b[:, 1] == 0.0)] = BED
    return tags


def _canonical(points: np.ndarray, tags: np.ndarray) -> BoundaryPolygon:
    """CCW, starting at the lowest, then leftmost tag-change corner (as ``chain_boundary``)."""
    pts, tags = np.asarray(points, dtype=float), np.asarray(tags, dtype=np.int64)
    if _signed_area(pts) < 0:
        pts = pts[::-1]
        tags = np.roll(tags[::-1], -1)
    corners = np.flatnonzero(np.roll(tags, 1) != tags)
    cand = corners if corners.size else np.arange(len(pts))
    start = cand[np.lexsort((pts[cand, 0], pts[cand, 1]))[0]]
    return BoundaryPolygon(np.roll(pts, -start, axis=0), np.roll(tags, -start))


def _ring_points(ring) -> np.ndarray:
    pts = np.asarray(ring.coords)[:-1, :2]
    same = np.all(pts == np.roll(pts, -1, axis=0), axis=1)
    return pts[~same]


def operate(poly: BoundaryPolygon, mesh_size: float,
            holes: list[BoundaryPolygon] = ()) -> Surgery | None:
    """The surgery of the module docstring on the outer loop ``poly`` (CCW, possibly
    self-crossing) with its ``holes``; None when there is no contact. ValueError when the
    mass would come apart in several pieces."""
    import shapely
    from shapely.geometry import Polygon, box

    pts, tags = np.asarray(poly.points, dtype=float), np.asarray(poly.edge_tags)
    crossing = not polygon_is_simple(pts) or any(not polygon_is_simple(h.points) for h in holes)
    near = near_contacts(pts, tags, mesh_size)
    bed = bed_contacts(pts, tags)
    if not (crossing or near or bed):
        return None
    area_before = loop_area(poly, list(holes))
    scale = float(np.ptp(pts, axis=0).max())
    mass = _region(pts)
    for hole in holes:
        mass = mass.difference(_region(np.asarray(hole.points)))
    n = len(pts)

    gap = CONTACT_GAP * mesh_size

    def along(a, b):      # the point of segment a → b at distance min(gap, |ab|/2) from a
        d = float(np.hypot(*(np.asarray(b) - a)))
        return a + min(gap, 0.5 * d) / max(d, 1e-300) * (np.asarray(b) - a)

    def bridge(k, q, e):   # the hull of p_k ± gap along its edges and q ± gap along e
        ends = [pts[k], along(pts[k], pts[k - 1]), along(pts[k], pts[(k + 1) % n]),
                q, along(q, e[0]), along(q, e[1])]
        return shapely.MultiPoint(np.vstack(ends)).convex_hull

    pieces = [mass]
    for k, j, q in near:
        pieces.append(bridge(k, q, (pts[j], pts[(j + 1) % n])))
    has_bed = bool(np.any((tags == BED) & (pts[:, 1] == 0.0) & (np.roll(pts[:, 1], -1) == 0.0)))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    solid = box(lo[0] - scale, -scale, hi[0] + scale, 0.0) if has_bed else None
    if solid is not None:
        pieces.append(solid)
    union = shapely.union_all(pieces)
    if union.geom_type != "Polygon":
        raise ValueError(f"surgery: the mass and its contacts form {len(union.geoms)} pieces")
    closed, kept, keep_rings = [], [], []
    for ring in union.interiors:
        area = Polygon(ring).area
        if area < close_area(mesh_size):
            closed.append(area)
        else:
            kept.append(area)
            keep_rings.append(ring)
    if not (crossing or near or closed):
        return None      # landed tips whose pockets are all kept: nothing to change
    union = Polygon(union.exterior, keep_rings)
    new = union.difference(solid) if solid is not None else union
    if new.geom_type != "Polygon":
        parts = [g for g in getattr(new, "geoms", []) if g.area > 0]
        if len(parts) != 1:
            raise ValueError(f"surgery: the mass would come apart in {len(parts)} pieces")
        new = parts[0]
    outer_pts = _snap_bed(_ring_points(new.exterior), scale)
    outer = _canonical(outer_pts, _retag(outer_pts, pts, tags, has_bed, scale))
    new_holes = []
    for ring in new.interiors:
        hp = _ring_points(ring)
        if _signed_area(hp) < 0:
            hp = hp[::-1]
        new_holes.append(BoundaryPolygon(hp, np.full(len(hp), SURFACE)))
    result = Surgery(outer, new_holes, area_before, loop_area(outer, new_holes),
                     crossings=crossing, near_contacts=len(near), bed_contacts=len(bed),
                     closed_pockets=closed, kept_pockets=kept)
    return result
