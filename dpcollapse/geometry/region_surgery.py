"""The boundary surgery and the area of each region on a mesh of two material regions (the
erodible layer under the mass, issue 49).

``geometry.surgery`` rebuilds a domain whose free surface touches the bed or itself as the
union of the mass. On the erodible bed the nose overturns onto the *layer*, the other
region: the domain's outer loop then touches itself (layer top and nose are both free
surface), and the interface between the regions must be re-cut through the union. With Ω
the domain before, L the layer (the union of its cells) and M the mass (Ω = L ∪ M):

    U = operate(∂Ω)                (``surgery.operate``: bridges, the bed solid, pockets
                                    closed below CLOSE_CELLS cells or kept as holes)
    L' = L,   M' = U \\ L           (the layer keeps its cells' polygon; everything the union
                                    added — the bridge over the gap, a closed pocket — is mass,
                                    and a crossing's overlap of the layer is counted once)

computed with shapely's fixed-precision overlay on a grid of GRID × the domain's size (the
polygons share every vertex exactly). M' in several pieces (other than slivers below
SLIVER × h², dropped and counted) is a ValueError: nothing of the mass is dropped. A
pocket enclosed by the mass and the layer is kept as the space between the two regions (its
boundary: the layer's top and the nose's underside, free surface); one enclosed by the
mass alone is a hole of M'.

Every remesh of the two regions then (``rebuild_regions``):

1. each region's boundary is chained from its cells (exact vertices; edges on the domain
   boundary keep their facet tag, the others are INTERFACE) — or taken from the surgery;
2. each region's outer loop is resampled as one region's (``polygon.resample``: clustered
   vertices dropped within ``max_area_change``, long edges split) with the vertices it
   shares with the other region fixed and its interface edges never split;
3. a vertex of one region lying on an edge of the other is inserted there (conforming);
4. with ``conserve_area``, the area of each region before the remesh is put back by moving
   its own free-surface vertices (not on the bed y = 0, not shared) along their normal
   (``polygon.offset_run``): A_L' = A_L and A_M' = A_M, each to round-off.

Edge tags after a surgery: shared by the two regions INTERFACE; on an old boundary edge its
tag; on y = 0 bed; the rest (bridges, crossing points) free surface.
"""

from __future__ import annotations

import numpy as np

from dpcollapse.geometry.mesher import BED, INTERFACE, LAYER, REGION_NAMES, SURFACE
from dpcollapse.geometry.polygon import (
    BoundaryPolygon,
    chain_loops,
    offset_run,
    polygon_is_simple,
    resample,
    signed_area,
)
from dpcollapse.geometry.surgery import Surgery, close_small_holes, operate

#: Overlay grid: coordinates snapped to this fraction of the domain's size (1e-11 m on a
#: 1 m domain: far below any cell, far above round-off).
GRID = 1e-11
#: Pieces of M' smaller than this × h² (overlay slivers) are dropped, their area counted.
SLIVER = 1e-6
#: Vertices of the overlay closer than this × h are merged into one.
MERGE = 1e-6


def region_loops(triangles: np.ndarray, tags: np.ndarray, edges: np.ndarray,
                 edge_tags: np.ndarray) -> dict[int, list[BoundaryPolygon]]:
    """{region tag: [outer loop, holes…]} chained from the cells of each region, each loop
    CCW (``polygon.chain_loops``); an edge on the domain boundary (``edges`` (m, 2, 2),
    ``edge_tags``) keeps its tag, an edge between the regions is INTERFACE."""
    tri = np.asarray(triangles, dtype=float).reshape(-1, 3, 2) + 0.0
    coords = np.concatenate([tri.reshape(-1, 2), np.asarray(edges, float).reshape(-1, 2) + 0.0])
    verts, inv = np.unique(coords, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    cell_v = inv[:3 * len(tri)].reshape(-1, 3)
    bnd_v = np.sort(inv[3 * len(tri):].reshape(-1, 2), axis=1)
    boundary_tag = {(int(a), int(b)): int(t) for (a, b), t in zip(bnd_v, edge_tags)}
    out = {}
    for tag in np.unique(tags):
        cv = cell_v[tags == tag]
        e = np.sort(np.concatenate([cv[:, [0, 1]], cv[:, [1, 2]], cv[:, [2, 0]]]), axis=1)
        keys, counts = np.unique(e, axis=0, return_counts=True)
        own = keys[counts == 1]
        etags = np.array([boundary_tag.get((int(a), int(b)), INTERFACE) for a, b in own])
        out[int(tag)] = chain_loops(verts[own], etags)
    return out


def _area(loops: list[BoundaryPolygon]) -> float:
    return loops[0].area - sum(abs(h.area) for h in loops[1:])


def _ring(coords) -> np.ndarray:
    pts = np.asarray(coords)[:-1, :2] + 0.0
    keep = np.any(pts != np.roll(pts, -1, axis=0), axis=1)
    pts = pts[keep]
    return pts if signed_area(pts) > 0 else pts[::-1]


def _on_segments(q: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """(k, m): point k within ``tol`` of segment m (a[m] → b[m])."""
    e = b - a
    len2 = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    t = np.clip(np.einsum("kjd,jd->kj", q[:, None, :] - a[None], e) / len2, 0.0, 1.0)
    return np.linalg.norm(a[None] + t[..., None] * e[None] - q[:, None, :], axis=2) <= tol


def _old_tags(points: np.ndarray, old: list[BoundaryPolygon], tol: float) -> np.ndarray:
    """Tags of a new loop's edges from the old boundary loops: an edge lying on an old edge
    takes its tag, on y = 0 bed, otherwise free surface."""
    a = np.concatenate([p.points for p in old])
    b = np.concatenate([np.roll(p.points, -1, axis=0) for p in old])
    t = np.concatenate([p.edge_tags for p in old])
    p, q = points, np.roll(points, -1, axis=0)
    on = _on_segments(p, a, b, tol) & _on_segments(q, a, b, tol) \
        & _on_segments(0.5 * (p + q), a, b, tol)
    tags = np.full(len(points), SURFACE, dtype=np.int64)
    some = on.any(axis=1)
    tags[some] = t[np.argmax(on[some], axis=1)]
    tags[(p[:, 1] == 0.0) & (q[:, 1] == 0.0)] = BED
    return tags


def _edge_set(loops) -> set:
    out = set()
    for pts in loops:
        nxt = np.roll(pts, -1, axis=0)
        out.update((tuple(p), tuple(q)) for p, q in zip(pts, nxt))
    return out


def _insert_points(pts: np.ndarray, tags: np.ndarray, extra: np.ndarray, tol: float):
    """``pts`` with the points of ``extra`` that lie strictly inside one of its edges
    inserted there (in order along the edge), the edge's tag on both pieces."""
    if not len(extra):
        return pts, tags
    known = {tuple(p) for p in pts}
    extra = np.array([q for q in extra if tuple(q) not in known]).reshape(-1, 2)
    if not len(extra):
        return pts, tags
    nxt = np.roll(pts, -1, axis=0)
    on = _on_segments(extra, pts, nxt, tol)
    if not on.any():
        return pts, tags
    new_p, new_t = [], []
    for i in range(len(pts)):
        new_p.append(pts[i])
        new_t.append(tags[i])
        here = extra[on[:, i]]
        if len(here):
            d = np.linalg.norm(here - pts[i], axis=1)
            for q in here[np.argsort(d)]:
                new_p.append(q)
                new_t.append(tags[i])
    return np.array(new_p), np.array(new_t, dtype=np.int64)


def _surgery_regions(done: Surgery, loops: dict, mesh_size: float, scale: float
                     ) -> dict[int, tuple[np.ndarray, list[np.ndarray]]]:
    """{tag: (outer points, [hole points])} of L' = L and M' = U \\ L (module docstring)."""
    import shapely
    from shapely.geometry import Polygon

    grid = GRID * scale
    layer_tag = LAYER if LAYER in loops else min(loops)
    mass_tag = next(t for t in loops if t != layer_tag)
    union = Polygon(done.outer.points, [h.points for h in done.holes])
    layer = Polygon(loops[layer_tag][0].points, [h.points for h in loops[layer_tag][1:]])
    layer = shapely.set_precision(layer, grid)
    mass = shapely.difference(shapely.set_precision(union, grid), layer, grid_size=grid)
    pieces = [g for g in getattr(mass, "geoms", [mass]) if g.geom_type == "Polygon"]
    big = [g for g in pieces if g.area >= SLIVER * mesh_size ** 2]
    if len(big) != 1:
        raise ValueError(f"surgery: the mass over the layer would come apart in {len(big)} pieces")
    if layer.geom_type != "Polygon":
        raise ValueError("surgery: the layer is not one polygon on the overlay grid")
    rings = [_ring(layer.exterior.coords), _ring(big[0].exterior.coords)]
    holes = [[_ring(r.coords) for r in poly.interiors] for poly in (layer, big[0])]
    flat = [_drop_needles(r, MERGE * mesh_size)
            for r in _merge_close(rings + holes[0] + holes[1], MERGE * mesh_size)]
    k = len(holes[0])
    return {layer_tag: (flat[0], flat[2:2 + k]), mass_tag: (flat[1], flat[2 + k:])}


def _drop_needles(pts: np.ndarray, width: float) -> np.ndarray:
    """The ring without its needles: vertices whose two edges leave in the same direction
    (a spike of zero width, e.g. a nose vertex the overlay put on the layer's edge), the
    shorter one ending within ``width`` of the longer one's line; repeated until none."""
    while len(pts) > 3:
        a = np.roll(pts, 1, axis=0) - pts
        b = np.roll(pts, -1, axis=0) - pts
        cross = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        longer = np.maximum(np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1))
        needle = (cross <= width * longer) & (np.einsum("ij,ij->i", a, b) > 0)
        if not needle.any():
            break
        pts = np.delete(pts, int(np.flatnonzero(needle)[0]), axis=0)
    return pts


def _merge_close(rings: list[np.ndarray], tol: float) -> list[np.ndarray]:
    """The rings with vertices closer than ``tol`` (overlay nodes a grid step apart) made
    one (the first of each cluster), consecutive repeats dropped."""
    from scipy.spatial import cKDTree

    allp = np.concatenate(rings)
    rep = np.arange(len(allp))
    for i, j in sorted(cKDTree(allp).query_pairs(tol)):
        ri, rj = rep[i], rep[j]
        while rep[ri] != ri:
            ri = rep[ri]
        while rep[rj] != rj:
            rj = rep[rj]
        rep[max(ri, rj)] = min(ri, rj)
    for i in range(len(rep)):
        while rep[rep[i]] != rep[i]:
            rep[i] = rep[rep[i]]
    merged = allp[rep]
    out, start = [], 0
    for r in rings:
        pts = merged[start:start + len(r)]
        start += len(r)
        keep = np.any(pts != np.roll(pts, -1, axis=0), axis=1)
        out.append(pts[keep])
    return out


def rebuild_regions(triangles: np.ndarray, tags: np.ndarray, edges: np.ndarray,
                    edge_tags: np.ndarray, mesh_size: float, size_of,
                    max_area_change: float, conserve_area: bool, surgery: bool):
    """The regions of a remesh of a two-region domain (module docstring): ([(points, edge
    tags, cell tag, holes)] for ``mesher.mesh_regions``, area change of the domain, number
    of boundary vertices, the ``Surgery`` done or None). ``size_of(tag)`` is the target edge
    length of a tag. ValueError when the boundary or a region is not a set of closed loops,
    or the mass would come apart."""
    old = chain_loops(edges, edge_tags)
    scale = float(np.ptp(old[0].points, axis=0).max())
    tol = 1e-9 * scale
    loops = region_loops(triangles, tags, edges, edge_tags)
    if len(loops) != 2:
        raise ValueError(f"{len(loops)} material regions (two expected)")
    before = {t: _area(ls) for t, ls in loops.items()}
    done = operate(old[0], mesh_size, old[1:]) if surgery else None
    if done is None and surgery:       # a kept pocket that shrank below A_close: closed
        _, closed = close_small_holes(old[1:], mesh_size)
        if closed:
            area = old[0].area - sum(abs(h.area) for h in old[1:])
            done = Surgery(old[0], old[1:], area, area, closed_pockets=[])
    if done is not None:
        kept, closed = close_small_holes(done.holes, mesh_size)
        if closed:
            done.closed_pockets += closed
            done.holes, done.area_after = kept, done.area_after + sum(closed)
        shapes = _surgery_regions(done, loops, mesh_size, scale)
        cut = {t: signed_area(o) - sum(abs(signed_area(h)) for h in hs)
               for t, (o, hs) in shapes.items()}
        polys = {}
        for t, (outer, holes) in shapes.items():
            polys[t] = ([outer, _old_tags(outer, old, tol)],
                        [[h, _old_tags(h, old, tol)] for h in holes])
        # edges shared by the two regions (after the mutual insertion below) are INTERFACE
    else:
        polys = {t: ([ls[0].points.copy(), ls[0].edge_tags.copy()],
                     [[h.points.copy(), h.edge_tags.copy()] for h in ls[1:]])
                 for t, ls in loops.items()}
    (t1, (o1, h1)), (t2, (o2, h2)) = polys.items()

    def conform():       # every vertex of one region on an edge of the other inserted there
        for mine, other in ((o1, o2), (o2, o1)):
            mine[0], mine[1] = _insert_points(mine[0], mine[1], other[0], tol)
        if done is not None:
            shared = _edge_set([o1[0]]) & {(q, p) for p, q in _edge_set([o2[0]])}
            for ring in (o1, o2):
                nxt = np.roll(ring[0], -1, axis=0)
                is_shared = np.array([(tuple(p), tuple(q)) in shared or (tuple(q), tuple(p))
                                      in shared for p, q in zip(ring[0], nxt)])
                ring[1] = np.where(is_shared, INTERFACE, ring[1])

    conform()

    def target(tag: int) -> float:
        return np.inf if tag == INTERFACE else size_of(tag)

    # the interface resampled once, in the first region (its vertices inside interface runs
    # may be dropped, long interface edges split), and the second region made to follow it
    inner = (o1[1] == INTERFACE) & (np.roll(o1[1], 1) == INTERFACE)
    keep = {tuple(p) for p in o2[0]}
    fixed = [i for i, p in enumerate(o1[0]) if tuple(p) in keep and not inner[i]]
    new, _ = resample(BoundaryPolygon(*o1), size_of, max_area_change, fixed=fixed)
    o1[0], o1[1] = np.array(new.points), np.array(new.edge_tags)
    follow = _follow_interface(o2[0], o2[1], o1[0], tol)
    if follow is not None:
        o2[0], o2[1] = follow
    keep = {tuple(p) for p in o1[0]}
    fixed = [i for i, p in enumerate(o2[0]) if tuple(p) in keep]
    new, _ = resample(BoundaryPolygon(*o2), target, max_area_change, fixed=fixed)
    o2[0], o2[1] = np.array(new.points), np.array(new.edge_tags)
    for holes in (h1, h2):
        for h in holes:
            new, _ = resample(BoundaryPolygon(*h), target, max_area_change)
            h[0], h[1] = np.array(new.points), np.array(new.edge_tags)
    conform()
    after = {}
    for t, (ring, holes) in ((t1, (o1, h1)), (t2, (o2, h2))):
        hole_area = sum(abs(signed_area(h[0])) for h in holes)
        if conserve_area:
            other = o2 if ring is o1 else o1
            shared = {tuple(p) for p in other[0]}
            movable = (ring[0][:, 1] > 0) & np.array([tuple(p) not in shared for p in ring[0]])
            moved = offset_run(ring[0], ring[1], SURFACE,
                               before[t] + hole_area - signed_area(ring[0]), movable=movable)
            if polygon_is_simple(moved) and _apart(moved, other[0]):
                ring[0] = moved
        after[t] = signed_area(ring[0]) - hole_area
    if done is not None:
        done.regions = {REGION_NAMES.get(t, str(t)): {
            "area_before": before[t], "surgery_change": cut[t] - before[t],
            "change": after[t] - before[t]} for t in (t1, t2)}
    regions = [(o[0], o[1].astype(np.int32), t, [(h[0], h[1].astype(np.int32)) for h in hs])
               for t, (o, hs) in ((t1, (o1, h1)), (t2, (o2, h2)))]
    nverts = sum(len(o[0]) + sum(len(h[0]) for h in hs) for o, hs in ((o1, h1), (o2, h2)))
    return regions, sum(after.values()) - sum(before.values()), nverts, done


def _follow_interface(pts: np.ndarray, tags: np.ndarray, other: np.ndarray, tol: float):
    """``pts`` with the vertices inside its interface runs that ``other`` no longer has
    dropped and those ``other`` added on its interface edges inserted; None when the result
    is not simple."""
    inner = (tags == INTERFACE) & (np.roll(tags, 1) == INTERFACE)
    known = {tuple(p) for p in other}
    keep = ~inner | np.array([tuple(p) in known for p in pts])
    # the tag of the edge leaving a kept vertex: the run it starts (interface runs stay)
    p, t = pts[keep], tags[keep]
    p, t = _insert_points(p, t, other, tol)
    return (p, t) if polygon_is_simple(p) else None


def _apart(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the polygons a and b overlap by no more than round-off."""
    from shapely.geometry import Polygon

    pa, pb = Polygon(a), Polygon(b)
    if not (pa.is_valid and pb.is_valid):
        return False
    return pa.intersection(pb).area <= 1e-12 * max(pa.area, pb.area)
