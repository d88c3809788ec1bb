"""The tagged boundary polygon of a 2D domain (pure numpy; no dolfinx).

A domain's boundary arrives as an unordered soup of straight, tagged edges (possibly with
duplicates when several MPI ranks report the same facet). :func:`chain_boundary` turns it
into one closed counter-clockwise :class:`BoundaryPolygon`; :func:`resample` improves the
vertex spacing before remeshing without moving any existing vertex: vertices are only kept
exactly, removed (Visvalingam–Whyatt, under an area budget) or added on existing edges.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = ["BoundaryPolygon", "chain_boundary", "chain_loops", "resample", "polygon_is_simple",
           "segments_intersect", "untangle", "remove_spikes", "clip_half_plane", "clip_right", "offset_run",
           "signed_area", "signed_volume"]


@dataclass(frozen=True, eq=False)
class BoundaryPolygon:
    """A closed polygon with one integer tag per edge.

    ``points`` (n, 2); ``edge_tags`` (n,) — edge i joins ``points[i]`` and
    ``points[(i + 1) % n]``. Both arrays are stored as read-only copies.
    """

    points: np.ndarray
    edge_tags: np.ndarray

    def __post_init__(self) -> None:
        pts = np.array(self.points, dtype=float).reshape(-1, 2)
        tags = np.array(self.edge_tags, dtype=np.int64).reshape(-1)
        if len(pts) != len(tags):
            raise ValueError(f"{len(pts)} points but {len(tags)} edge tags")
        if len(pts) < 3:
            raise ValueError(f"a polygon needs at least 3 points, got {len(pts)}")
        pts.flags.writeable = False
        tags.flags.writeable = False
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "edge_tags", tags)

    def __len__(self) -> int:
        return len(self.points)

    @property
    def area(self) -> float:
        """Signed area (shoelace); positive for a counter-clockwise polygon."""
        return _signed_area(self.points)

    @property
    def corners(self) -> np.ndarray:
        """Indices of points where the incoming edge's tag differs from the outgoing one's."""
        return np.flatnonzero(np.roll(self.edge_tags, 1) != self.edge_tags)

    @property
    def edge_lengths(self) -> np.ndarray:
        """(n,) length of edge i (from point i to point i + 1)."""
        return np.linalg.norm(np.roll(self.points, -1, axis=0) - self.points, axis=1)

    @property
    def min_edge_length(self) -> float:
        return float(self.edge_lengths.min())

    def segments(self) -> list[tuple[int, list[int]]]:
        """Runs of equal tag as ``(tag, [point indices])``, each including both end corners.

        Runs follow the polygon order starting at the first corner. Without any corner the
        whole loop is one run ``[0, 1, ..., n - 1, 0]`` (start point repeated at the end).
        """
        n = len(self.points)
        corners = self.corners
        if corners.size == 0:
            return [(int(self.edge_tags[0]), list(range(n)) + [0])]
        runs = []
        for a, b in zip(corners, np.roll(corners, -1)):
            stop = b if b > a else b + n
            idx = [int(i % n) for i in range(a, stop + 1)]
            runs.append((int(self.edge_tags[a]), idx))
        return runs


# ----------------------------------------------------------------------------- helpers
def _signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def signed_area(points: np.ndarray) -> float:
    """A = ∫∫ dx dy of a polygon (shoelace; positive counter-clockwise) [m²]."""
    return _signed_area(np.asarray(points, dtype=float))


def signed_volume(points: np.ndarray) -> float:
    """V = 2π ∫∫ x dx dy [m³]: the volume of the body of revolution of a polygon in x ≥ 0
    about the axis x = 0 (Pappus; the first moment (1/6) Σ (x_i + x_{i+1}) c_i with
    c_i = x_i y_{i+1} − x_{i+1} y_i; positive counter-clockwise)."""
    pts = np.asarray(points, dtype=float)
    x, y = pts[:, 0], pts[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    return 2.0 * np.pi * float(np.sum((x + xn) * (x * yn - xn * y))) / 6.0


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Twice the signed area of triangles (a, b, c), broadcasting over leading axes."""
    return ((b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
            - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0]))


def segments_intersect(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray,
                       q2: np.ndarray) -> np.ndarray:
    """Whether closed segments [p1, p2] and [q1, q2] share a point (touching counts).

    All arguments (..., 2), broadcast together; returns a boolean array.
    """
    o1, o2 = _orient(p1, p2, q1), _orient(p1, p2, q2)
    o3, o4 = _orient(q1, q2, p1), _orient(q1, q2, p2)
    bbox = ((np.minimum(p1[..., 0], p2[..., 0]) <= np.maximum(q1[..., 0], q2[..., 0]))
            & (np.minimum(q1[..., 0], q2[..., 0]) <= np.maximum(p1[..., 0], p2[..., 0]))
            & (np.minimum(p1[..., 1], p2[..., 1]) <= np.maximum(q1[..., 1], q2[..., 1]))
            & (np.minimum(q1[..., 1], q2[..., 1]) <= np.maximum(p1[..., 1], p2[..., 1])))
    return bbox & (o1 * o2 <= 0) & (o3 * o4 <= 0)


def polygon_is_simple(points: np.ndarray, block: int = 512) -> bool:
    """True if no two non-adjacent edges of the closed polygon share a point.

    O(n²) but vectorized in row blocks with a bounding-box prefilter; fine for a few
    thousand vertices. Adjacent edges that fold back onto each other are also rejected.
    """
    p = np.asarray(points, dtype=float)
    n = len(p)
    if n < 3:
        return False
    a, b = p, np.roll(p, -1, axis=0)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    # adjacent edges i, i+1 share point i+1: reject if they fold back collinearly
    nxt = np.roll(b, -1, axis=0)
    fold = (_orient(a, b, nxt) == 0) & (np.einsum("ij,ij->i", a - b, nxt - b) > 0)
    if fold.any():
        return False
    for start in range(0, n, block):
        i = np.arange(start, min(start + block, n))
        ov = ((lo[i, None, 0] <= hi[None, :, 0]) & (lo[None, :, 0] <= hi[i, None, 0])
              & (lo[i, None, 1] <= hi[None, :, 1]) & (lo[None, :, 1] <= hi[i, None, 1]))
        ii, jj = np.nonzero(ov)
        ii = i[ii]
        keep = (jj > ii + 1) & ~((ii == 0) & (jj == n - 1))
        ii, jj = ii[keep], jj[keep]
        if ii.size and segments_intersect(a[ii], b[ii], a[jj], b[jj]).any():
            return False
    return True


# ----------------------------------------------------------------------------- chaining
def chain_boundary(edges: np.ndarray, tags: np.ndarray, simple: bool = True) -> BoundaryPolygon:
    """Chain an unordered set of tagged edges into one closed CCW polygon.

    ``edges`` (m, 2, 2), ``tags`` (m,). Duplicate edges (same two end points in either
    direction, bitwise-identical coordinates) are merged; duplicates with different tags
    are an error. The loop starts at a tag-change corner when there is one (the lowest,
    then leftmost such corner, so the result does not depend on the input order).

    Raises ValueError unless the edges form exactly one closed loop, simple unless
    ``simple`` is False (a folded free surface, for :func:`untangle`).
    """
    edges = np.asarray(edges, dtype=float).reshape(-1, 2, 2)
    tags = np.asarray(tags).reshape(-1)
    if len(edges) != len(tags):
        raise ValueError(f"{len(edges)} edges but {len(tags)} tags")
    if len(edges) < 3:
        raise ValueError(f"need at least 3 edges to close a loop, got {len(edges)}")
    coords = edges.reshape(-1, 2) + 0.0  # + 0.0 turns -0.0 into 0.0
    verts, inv = np.unique(coords, axis=0, return_inverse=True)
    inv = inv.reshape(-1, 2)
    if np.any(inv[:, 0] == inv[:, 1]):
        bad = edges[np.flatnonzero(inv[:, 0] == inv[:, 1])[0], 0]
        raise ValueError(f"zero-length boundary edge at {bad.tolist()}")
    keys = np.sort(inv, axis=1)
    ukeys, first, ekey = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    ekey = ekey.reshape(-1)
    utags = tags[first]
    if np.any(utags[ekey] != tags):
        k = np.flatnonzero(utags[ekey] != tags)[0]
        raise ValueError(f"duplicate boundary edge {edges[k].tolist()} has conflicting tags "
                         f"{utags[ekey[k]]} and {tags[k]}")
    nv, ne = len(verts), len(ukeys)
    degree = np.bincount(ukeys.ravel(), minlength=nv)
    if np.any(degree != 2):
        bad = np.flatnonzero(degree != 2)
        raise ValueError(
            f"boundary edges do not form a simple closed loop: {bad.size} vertices have "
            f"degree != 2 (e.g. {verts[bad[0]].tolist()} has degree {degree[bad[0]]}); "
            "open chain, branching or figure-eight boundary")
    graph = coo_matrix((np.ones(ne), (ukeys[:, 0], ukeys[:, 1])), shape=(nv, nv))
    ncomp, _ = connected_components(graph, directed=False)
    if ncomp != 1:
        raise ValueError(f"boundary edges form {ncomp} closed loops, expected exactly one")

    # walk the loop: incident edges of each vertex (exactly two each)
    ends = ukeys.ravel()
    inc = (np.argsort(ends, kind="stable") // 2).reshape(nv, 2)
    order = np.empty(nv, dtype=np.int64)
    etag = np.empty(nv, dtype=np.int64)
    v, e = 0, inc[0, 0]
    for s in range(nv):
        order[s] = v
        etag[s] = utags[e]
        a, b = ukeys[e]
        v = b if a == v else a
        e = inc[v, 1] if inc[v, 0] == e else inc[v, 0]
    pts = verts[order]
    if simple and not polygon_is_simple(pts):
        raise ValueError(f"boundary loop intersects itself{where_it_crosses(pts, etag)}")
    if _signed_area(pts) == 0:
        raise ValueError("boundary loop has zero area")
    if _signed_area(pts) < 0:
        pts = pts[::-1]
        etag = np.roll(etag[::-1], -1)  # reversed edge i was old edge n - 2 - i
    corners = np.flatnonzero(np.roll(etag, 1) != etag)
    cand = corners if corners.size else np.arange(nv)
    start = cand[np.lexsort((pts[cand, 0], pts[cand, 1]))[0]]
    pts, etag = np.roll(pts, -start, axis=0), np.roll(etag, -start)
    return BoundaryPolygon(pts, etag)


def chain_loops(edges: np.ndarray, tags: np.ndarray) -> list[BoundaryPolygon]:
    """The closed loops of a boundary with holes (``chain_boundary`` on each connected set
    of edges, possibly folded), each CCW; the outer loop (largest area) first."""
    edges = np.asarray(edges, dtype=float).reshape(-1, 2, 2)
    tags = np.asarray(tags).reshape(-1)
    coords = edges.reshape(-1, 2) + 0.0
    _, inv = np.unique(coords, axis=0, return_inverse=True)
    inv = inv.reshape(-1, 2)
    nv = int(inv.max()) + 1 if inv.size else 0
    graph = coo_matrix((np.ones(len(inv)), (inv[:, 0], inv[:, 1])), shape=(nv, nv))
    ncomp, label = connected_components(graph, directed=False)
    if ncomp == 1:
        return [chain_boundary(edges, tags, simple=False)]
    loops = [chain_boundary(edges[label[inv[:, 0]] == c], tags[label[inv[:, 0]] == c],
                            simple=False) for c in range(ncomp)]
    return sorted(loops, key=lambda loop: -loop.area)


def where_it_crosses(points: np.ndarray, edge_tags: np.ndarray) -> str:
    """' at (x, y): edges tagged a and b' for the first pair of non-adjacent edges (in
    polygon order) that share a point; '' if none is found (an edge folding back)."""
    a, b = points, np.roll(points, -1, axis=0)
    n = len(points)
    for i in range(n):
        j = np.arange(i + 2, n if i > 0 else n - 1)
        if not j.size:
            continue
        hit = segments_intersect(a[i], b[i], a[j], b[j])
        if hit.any():
            k = int(j[np.argmax(hit)])
            x, y = 0.5 * (a[i] + b[i])
            return (f" at ({x:.4f}, {y:.4f}) m: edges tagged {int(edge_tags[i])} and "
                    f"{int(edge_tags[k])} cross (polygon edges {i} and {k} of {n})")
    return ""


# ----------------------------------------------------------------------------- untangling
def _first_crossing(p: np.ndarray) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of non-adjacent edges of the closed polygon ``p`` that
    share a point (edge i joins p[i] and p[i+1]); None when the polygon is simple."""
    n = len(p)
    a, b = p, np.roll(p, -1, axis=0)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]
    hit = np.flatnonzero(segments_intersect(a[i], b[i], a[j], b[j]))
    if hit.size == 0:
        return None
    return int(i[hit[0]]), int(j[hit[0]])


def _crossing_point(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """A point shared by segments [a, b] and [c, d] (their intersection; for overlapping
    collinear segments, the end point of one that lies on the other)."""
    r, s = b - a, d - c
    den = r[0] * s[1] - r[1] * s[0]
    if den != 0:
        t = ((c[0] - a[0]) * s[1] - (c[1] - a[1]) * s[0]) / den
        return a + min(max(t, 0.0), 1.0) * r
    for q in (c, d, a, b):
        return q.copy()


def untangle(poly_points: np.ndarray, edge_tags: np.ndarray,
             fixed: Iterable[int] = ()) -> tuple[np.ndarray, np.ndarray, float]:
    """Remove the self-intersections of a closed polygon (a free surface folded over
    itself): at the first crossing of edges i < j at the point X, the polygon splits into
    the loop p[i+1..j] + X and the rest p[..i] + X + p[j+1..]; the loop with the smaller
    |area| is dropped (the rest keeps every ``fixed`` point index, e.g. the corners), and
    so on until the polygon is simple. Returns (points, edge tags, signed area change);
    the area change is minus the signed area of the dropped loops (a loop traversed
    clockwise — an inverted fold — had counted negatively)."""
    pts = np.asarray(poly_points, dtype=float).copy()
    tags = np.asarray(edge_tags, dtype=np.int64).copy()
    fixed = np.zeros(len(pts), dtype=bool) if not len(list(fixed)) else np.isin(
        np.arange(len(pts)), np.asarray(list(fixed)))
    area0 = _signed_area(pts)
    while len(pts) > 3:
        pair = _first_crossing(pts)
        if pair is None:
            break
        i, j = pair
        n = len(pts)
        x = _crossing_point(pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n])
        inner = np.arange(i + 1, j + 1)
        outer = np.concatenate([np.arange(0, i + 1), np.arange(j + 1, n)])
        loop_in = np.vstack([pts[inner], x])
        loop_out = np.vstack([pts[: i + 1], x, pts[j + 1:]])
        keep_inner = (fixed[inner].sum() > fixed[outer].sum()
                      or (fixed[inner].sum() == fixed[outer].sum()
                          and abs(_signed_area(loop_in)) > abs(_signed_area(loop_out))))
        if keep_inner:   # edges i+1..j-1, then j (up to X), then X -> p[i+1] with edge i's tag
            pts = loop_in
            tags = np.concatenate([tags[i + 1: j + 1], [tags[i]]])
            fixed = np.concatenate([fixed[inner], [False]])
        else:            # edges ..i (p[i] -> X), then X -> p[j+1] with edge j's tag
            pts = loop_out
            tags = np.concatenate([tags[: i + 1], [tags[j]], tags[j + 1:]])
            fixed = np.concatenate([fixed[: i + 1], [False], fixed[j + 1:]])
        # a crossing at a vertex leaves a zero-length edge: drop the repeated point
        same = np.all(pts == np.roll(pts, -1, axis=0), axis=1)
        if same.any():
            pts, tags, fixed = pts[~same], tags[~same], fixed[~same]
    return pts, tags, _signed_area(pts) - area0


def remove_spikes(points: np.ndarray, edge_tags: np.ndarray, tag: int,
                  min_angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop the vertices inside runs of ``tag`` whose interior angle (between the edges to
    their two neighbours) is below ``min_angle`` [deg] — hairpin spikes of a crumpled free
    surface that do not cross anything, so :func:`untangle` leaves them — one at a time,
    sharpest first, as long as the polygon stays simple. Returns (points, edge tags)."""
    pts = np.asarray(points, dtype=float)
    tags = np.asarray(edge_tags, dtype=np.int64)
    while len(pts) > 3:
        a, b = np.roll(pts, 1, axis=0) - pts, np.roll(pts, -1, axis=0) - pts
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
        angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        inner = (tags == tag) & (np.roll(tags, 1) == tag)
        candidates = np.flatnonzero(inner & (angle < min_angle))
        removed = False
        for i in candidates[np.argsort(angle[candidates])]:
            keep = np.arange(len(pts)) != i
            if polygon_is_simple(pts[keep]):
                pts, tags = pts[keep], tags[keep]    # edge i-1 now runs to point i+1
                removed = True
                break
        if not removed:
            break
    return pts, tags


def clip_half_plane(points: np.ndarray, edge_tags: np.ndarray, origin, normal,
                    cut_tag: int) -> tuple[np.ndarray, np.ndarray]:
    """The part n·(p − origin) ≤ 0 of a closed polygon (Sutherland–Hodgman against one
    half-plane): kept pieces of edges keep their tags, the new edges along the line get
    ``cut_tag``. Returns (points, edge tags); the caller checks simplicity (a polygon that
    crosses the line several times gives edges along it)."""
    pts = np.asarray(points, dtype=float)
    tags = np.asarray(edge_tags, dtype=np.int64)
    dist = (pts - np.asarray(origin, dtype=float)) @ np.asarray(normal, dtype=float)
    n = len(pts)
    out, out_tags = [], []
    for i in range(n):
        j = (i + 1) % n
        ina, inb = dist[i] <= 0, dist[j] <= 0
        if ina:
            out.append(pts[i])
            out_tags.append(int(tags[i]))       # edge a -> b (or a -> crossing)
        if ina != inb:
            s_ = dist[i] / (dist[i] - dist[j])
            out.append(pts[i] + s_ * (pts[j] - pts[i]))
            # leaving: from the crossing along the cut line; entering: crossing -> b
            out_tags.append(cut_tag if ina else int(tags[i]))
    pts_out, tags_out = np.array(out), np.array(out_tags, dtype=np.int64)
    same = np.all(pts_out == np.roll(pts_out, -1, axis=0), axis=1)
    return pts_out[~same], tags_out[~same]


def clip_right(points: np.ndarray, edge_tags: np.ndarray, x_cut: float,
               cut_tag: int) -> tuple[np.ndarray, np.ndarray]:
    """The part x ≤ ``x_cut`` of a closed polygon (``clip_half_plane``)."""
    return clip_half_plane(points, edge_tags, (x_cut, 0.0), (1.0, 0.0), cut_tag)


def offset_run(points: np.ndarray, edge_tags: np.ndarray, tag: int,
               area_change: float, movable: np.ndarray | None = None,
               measure=signed_area) -> np.ndarray:
    """Move the vertices inside the runs of edges tagged ``tag`` (both adjacent edges of
    that tag; corners stay; only where ``movable``, a boolean mask, when given) along their outward
    normal (the mean of the two edge normals
    of a CCW polygon) by one distance s chosen so that the signed area changes by
    ``area_change`` (secant steps on A(s), which is quadratic in s, to round-off).
    ``measure``: ``signed_area`` or ``signed_volume`` (the body of revolution's, cubic in s:
    the same secant steps; ``area_change`` is then a volume)."""
    pts = np.asarray(points, dtype=float)
    tags = np.asarray(edge_tags)
    inner = (tags == tag) & (np.roll(tags, 1) == tag)        # vertex i: edges i-1 and i
    e = np.roll(pts, -1, axis=0) - pts
    normal = np.stack([e[:, 1], -e[:, 0]], axis=1)            # outward for a CCW polygon
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    vn = normal + np.roll(normal, 1, axis=0)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
    vn[~inner if movable is None else ~(inner & movable)] = 0.0
    area0 = measure(pts)

    def change(s: float) -> float:
        return measure(pts + s * vn) - area0

    length = float(np.sum(np.linalg.norm(e, axis=1)[tags == tag]))
    if measure is not signed_area:    # the first step from the measure's own rate at s = 0
        rate = (change(1e-9 * max(length, 1e-300)) / (1e-9 * max(length, 1e-300)))
        length = rate if rate > 0 else length
    if not inner.any() or length == 0 or area_change == 0:
        return pts.copy()
    s0, s1 = 0.0, area_change / length
    f0, f1 = -area_change, change(s1) - area_change
    for _ in range(20):
        if f1 == f0 or abs(f1) <= 1e-13 * abs(area0):
            break
        s0, s1 = s1, s1 - f1 * (s1 - s0) / (f1 - f0)
        f0, f1 = f1, change(s1) - area_change
    return pts + s1 * vn


# ----------------------------------------------------------------------------- resampling
#: An edge shorter than this fraction of its target size (e.g. the film trim's cut falling
#: micrometres beside a bed vertex) is merged away by the resampling even when the merged
#: edge is longer than the target (it is then split on itself if longer than 1.5 targets):
#: left, gmsh meshes it with slivers (0.6° beside a 5.6 µm edge at 5 mm cells, issue 49).
SHORT_EDGE = 0.1


def resample(poly: BoundaryPolygon, target_size: float | Callable[[int], float],
             max_area_change: float, fixed: Iterable[int] | None = None
             ) -> tuple[BoundaryPolygon, float]:
    """Improve the vertex spacing of ``poly`` for remeshing without moving anything.

    * corners (tag changes) and the ``fixed`` point indices are never moved or removed
      (without any corner, point 0 is treated as one);
    * interior vertices of each run are removed by Visvalingam–Whyatt (smallest triangle
      area first) while the *sum of absolute* removed-triangle areas stays
      ≤ ``max_area_change`` (this bounds the area of the symmetric difference between
      the old and the new polygon, hence also |net area change|), the merged edge is
      ≤ the target size of the run's tag (or one of the vertex's two edges is shorter than
      ``SHORT_EDGE`` × that target: a sliver edge goes whatever the merged length), and the
      polygon stays simple;
    * edges longer than 1.5 × target are then split into ``max(2, round(L / target))``
      equal parts by points inserted on the edge.

    Existing vertices are kept bitwise or removed. ``target_size`` is a number or a
    callable ``tag -> size``. Returns the new polygon (starting at the old point 0 if it
    survived) and the signed area change (new − old).
    """
    size_of = target_size if callable(target_size) else (lambda _t, s=float(target_size): s)
    if max_area_change < 0:
        raise ValueError("max_area_change must be >= 0")
    pts = np.asarray(poly.points)
    tags = np.asarray(poly.edge_tags)
    n = len(pts)
    targets = {int(t): float(size_of(int(t))) for t in np.unique(tags)}
    if any(not (s > 0) for s in targets.values()):
        raise ValueError(f"target sizes must be positive, got {targets}")

    protected = np.zeros(n, dtype=bool)
    protected[poly.corners] = True
    if fixed is not None:
        fixed = np.asarray(list(fixed), dtype=np.int64)
        if fixed.size and (fixed.min() < -n or fixed.max() >= n):
            raise ValueError(f"fixed indices out of range for {n} points")
        protected[fixed] = True
    if not protected.any():
        protected[0] = True

    alive = _visvalingam(pts, tags, protected, targets, float(max_area_change))

    # rebuild in order, splitting long edges
    idx = np.flatnonzero(alive)
    out_pts, out_tags = [], []
    for i, j in zip(idx, np.roll(idx, -1)):
        t = int(tags[i])  # tag of the run between two alive vertices
        a, b = pts[i], pts[j]
        out_pts.append(a[None])
        h = targets[t]
        length = float(np.hypot(*(b - a)))
        k = max(2, int(round(length / h))) if length > 1.5 * h else 1
        if k > 1:
            s = np.arange(1, k)[:, None] / k
            out_pts.append(a + s * (b - a))
        out_tags.append(np.full(k, t, dtype=np.int64))
    new = BoundaryPolygon(np.concatenate(out_pts), np.concatenate(out_tags))
    return new, new.area - poly.area


def _visvalingam(pts: np.ndarray, tags: np.ndarray, protected: np.ndarray,
                 targets: dict[int, float], budget: float) -> np.ndarray:
    """Boolean mask of the vertices kept by the constrained Visvalingam–Whyatt pass."""
    n = len(pts)
    nxt = np.roll(np.arange(n), -1)
    prv = np.roll(np.arange(n), 1)
    alive = np.ones(n, dtype=bool)
    version = np.zeros(n, dtype=np.int64)
    tree = cKDTree(pts)
    xy = pts.tolist()

    def tri(i: int) -> float:
        (ax, ay), (bx, by), (cx, cy) = xy[prv[i]], xy[i], xy[nxt[i]]
        return 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))

    heap = [(abs(tri(i)), 0, i) for i in range(n) if not protected[i]]
    heapq.heapify(heap)
    spent, count = 0.0, n
    while heap and count > 3:
        area, ver, v = heapq.heappop(heap)
        if not alive[v] or ver != version[v]:
            continue
        if spent + area > budget:
            break  # every remaining candidate has a larger area
        p, q = prv[v], nxt[v]
        target = targets[int(tags[v])]
        sliver = min(math.dist(xy[p], xy[v]), math.dist(xy[v], xy[q])) < SHORT_EDGE * target
        if math.dist(xy[p], xy[q]) > target and not sliver:
            continue
        if not _removal_keeps_simple(pts, tree, alive, prv, nxt, p, v, q):
            continue
        alive[v] = False
        nxt[p], prv[q] = q, p
        spent += area
        count -= 1
        for w in (p, q):
            if not protected[w]:
                version[w] += 1
                heapq.heappush(heap, (abs(tri(w)), int(version[w]), w))
    return alive


def _removal_keeps_simple(pts: np.ndarray, tree: cKDTree, alive: np.ndarray,
                          prv: np.ndarray, nxt: np.ndarray, p: int, v: int, q: int) -> bool:
    """Whether replacing edges (p, v), (v, q) of a simple polygon by (p, q) keeps it simple.

    An edge hitting the new segment [p, q] cannot cross [p, v] or [v, q], so it has an end
    point in the closed triangle (p, v, q): only edges at alive vertices inside the
    triangle's circumscribing ball are tested. The two edges adjacent to [p, q] are only
    checked for folding back onto it.
    """
    P, V, Q = pts[p], pts[v], pts[q]
    if prv[p] == q:
        return False
    for a, b, c in ((pts[prv[p]], P, Q), (pts[nxt[q]], Q, P)):
        if _orient(a, b, c) == 0 and np.dot(a - b, c - b) > 0:
            return False
    lo, hi = np.minimum(np.minimum(P, V), Q), np.maximum(np.maximum(P, V), Q)
    centre = 0.5 * (lo + hi)
    near = np.asarray(tree.query_ball_point(centre, 0.5 * np.hypot(*(hi - lo)) * (1 + 1e-9)),
                      dtype=np.int64)
    near = near[alive[near]]
    near = near[(near != p) & (near != v) & (near != q)]
    if near.size == 0:
        return True
    ea = np.concatenate([near, prv[near]])
    eb = np.concatenate([nxt[near], near])
    keep = ~np.isin(ea, (p, v, q)) & ~np.isin(eb, (p, v, q))
    ea, eb = ea[keep], eb[keep]
    if ea.size == 0:
        return True
    return not segments_intersect(P, Q, pts[ea], pts[eb]).any()
