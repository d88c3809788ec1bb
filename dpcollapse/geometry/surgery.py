"""Boundary surgery at remeshing: a free surface that folds onto the bed or onto the mass
itself is rebuilt as the union of what the mass occupies (polygon booleans of shapely ≥ 2).

A *contact* is one of
- a crossing: two boundary edges share a point (the mesh moved a nose through the surface);
- a near contact: a free-surface vertex p and a boundary edge e with dist(p, e) < g,
  g = CONTACT_GAP·h, the segment between them through air (its midpoint outside the mass)
  and p at least CONTACT_ARC·h from e along the boundary (not a neighbour);
- a bed contact: a landed nose tip, a free-surface vertex on the bed y = 0 between two
  free-surface edges (the mesh motion lands nodes exactly on the bed: no gap needed);
- a notch: a free-surface vertex p above the bed (behind the toe) closer to it than g, the
  mass between them (a neck), at the bottom of a V of the free surface: its two neighbours
  higher, and the surface at arc length g from p on either side at least NOTCH_RISE·y_p
  high (a breaking front leaning over a thin nose, a notch of air reaching to the bed).

The surgery (``operate``) then builds, with M the region of nonzero winding number of the
boundary loop minus the existing holes (a folded loop's doubly covered part counts once),
B = the bed solid y ≤ 0 (when the boundary has bed edges) and T the bridge triangles
of each near contact: the convex hull of p, of q its closest point on e and of the points
at distance g from p along its two edges and from q along e (so that it overlaps the mass,
not only touches it); of each notch: the convex hull of the free surface within arc length
g of p and of q = (x_p, 0), its foot on the bed (the notch's bottom filled up to the chord
between the surface points at arc g: the neck closed onto the bed contact):

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
#: A free-surface vertex p closer to the bed than the gap is a notch when the surface at arc
#: length gap from it on either side is at least this many times higher than p.
NOTCH_RISE = 2.0
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
    notches: int = 0
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
        if self.notches:
            what.append(f"{self.notches} notch(es) closed to the bed")
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


def _on_bed_below(p: np.ndarray, tags: np.ndarray, k: int) -> int | None:
    """The bed edge (on y = 0) under vertex k, or None (k ahead of the toe, or no bed)."""
    a, b = p, np.roll(p, -1, axis=0)
    under = ((tags == BED) & (a[:, 1] == 0.0) & (b[:, 1] == 0.0)
             & (np.minimum(a[:, 0], b[:, 0]) <= p[k, 0]) & (np.maximum(a[:, 0], b[:, 0]) >= p[k, 0]))
    hits = np.flatnonzero(under)
    return int(hits[0]) if hits.size else None


def _clear_below(p: np.ndarray, k: int) -> bool:
    """No boundary edge other than vertex k's own crosses the open segment from p_k down to
    the bed (x_k, 0)."""
    x, y = p[k]
    a, b = p, np.roll(p, -1, axis=0)
    n = len(p)
    own = np.zeros(n, dtype=bool)
    own[[k, (k - 1) % n]] = True
    span = (np.minimum(a[:, 0], b[:, 0]) <= x) & (np.maximum(a[:, 0], b[:, 0]) >= x) & ~own
    span &= a[:, 0] != b[:, 0]
    t = (x - a[span, 0]) / (b[span, 0] - a[span, 0])
    yc = a[span, 1] + t * (b[span, 1] - a[span, 1])
    return not np.any((yc > 0.0) & (yc < y))


def _walk(p: np.ndarray, k: int, distance: float, step: int) -> np.ndarray:
    """The loop's vertices from k (excluded) along direction ``step`` (±1) up to arc length
    ``distance``, ending with the point at exactly that arc length (or where the loop ends)."""
    n = len(p)
    out, left, i = [], distance, k
    for _ in range(n - 1):
        j = (i + step) % n
        d = float(np.hypot(*(p[j] - p[i])))
        if d >= left:
            out.append(p[i] + left / max(d, 1e-300) * (p[j] - p[i]))
            break
        out.append(p[j])
        left -= d
        i = j
    return np.array(out).reshape(-1, 2)


def notch_contacts(points: np.ndarray, tags: np.ndarray, mesh_size: float
                   ) -> list[tuple[int, np.ndarray]]:
    """Notches (module docstring): (vertex k, the free surface within arc length g of it on
    both sides with p_k, in loop order), one per notch bottom."""
    p = np.asarray(points, dtype=float)
    tags = np.asarray(tags)
    gap = CONTACT_GAP * mesh_size
    surface_vertex = (tags == SURFACE) & (np.roll(tags, 1) == SURFACE)
    y = p[:, 1]
    bottom = (surface_vertex & (y > 0.0) & (y < gap)
              & (np.roll(y, 1) > y) & (np.roll(y, -1) > y))
    out = []
    for k in np.flatnonzero(bottom):
        k = int(k)
        if _on_bed_below(p, tags, k) is None or not _clear_below(p, k):
            continue
        if _winding(p, [p[k, 0], 0.5 * p[k, 1]])[0] == 0:
            continue                          # air under p: a near contact, not a neck
        back, ahead = _walk(p, k, gap, -1), _walk(p, k, gap, +1)
        if not (len(back) and len(ahead)):
            continue
        if min(back[-1, 1], ahead[-1, 1]) < NOTCH_RISE * y[k]:
            continue                          # a shallow dip of a thin film, not a notch
        out.append((k, np.vstack([back[::-1], p[k][None], ahead])))
    return out


def contact_kinds(poly: BoundaryPolygon, mesh_size: float,
                  holes: list[BoundaryPolygon] = ()) -> list[str]:
    """Which contacts (module docstring) the boundary has: "crossing", "self-contact",
    "bed contact", "notch"; empty when none."""
    pts, tags = np.asarray(poly.points), np.asarray(poly.edge_tags)
    found = []
    if not polygon_is_simple(pts) or any(not polygon_is_simple(h.points) for h in holes):
        found.append("crossing")
    if near_contacts(pts, tags, mesh_size):
        found.append("self-contact")
    if bed_contacts(pts, tags):
        found.append("bed contact")
    if notch_contacts(pts, tags, mesh_size):
        found.append("notch")
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
    notches = notch_contacts(pts, tags, mesh_size)
    if not (crossing or near or bed or notches):
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
    for k, window in notches:   # the notch's bottom filled, down to its foot on the bed
        foot = np.array([[pts[k, 0], 0.0]])
        pieces.append(shapely.MultiPoint(np.vstack([window, foot])).convex_hull)
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
    if not (crossing or near or notches or closed):
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
                     notches=len(notches),
                     closed_pockets=closed, kept_pockets=kept)
    return result
