"""The exact conservative remap of cellwise-constant fractions (c, c_L) between two triangle
meshes of the same box (the two-phase model's adaptive mesh, ``adaptive``).

For an old mesh {K_i} carrying c_i and a new mesh {T_j} of the same region::

    c_j = Σ_i c_i |K_i ∩ T_j| / |T_j|

Each overlap |K_i ∩ T_j| is exact up to round-off: K_i is clipped by the three half-planes
of T_j (Sutherland–Hodgman, as ``overlap``, here for many pairs at once with numpy) and the
clipped polygon's area taken by the shoelace formula. Since the T_j tile every K_i,
Σ_j |K_i ∩ T_j| = |K_i| and Σ_j |T_j| c_j = Σ_i |K_i| c_i: ∫ c is conserved up to
round-off, a constant stays constant, and c_j is a convex combination of the c_i (its
bounds are kept).

The candidate pairs come from a spatial search: the old cells are split into size classes
(circumscribing radius about their centroid within a factor 2), one cKDTree per class, and
each new cell queries every class within (its radius + the class's largest radius); pairs
whose bounding boxes do not overlap are dropped before clipping. The work is O(N) for
meshes whose sizes vary smoothly. Old cells whose values are all zero are skipped (they
add nothing). Under MPI each rank remaps its own new cells from the old cells of every
rank (``flow.TwoPhaseFlow.snapshot`` gathers them).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: vertices a clipped polygon can reach (a triangle clipped by three half-planes has ≤ 6)
_SLOTS = 8
#: pairs clipped at once (memory: ~ 100 bytes × _SLOTS per pair and temporary)
_CHUNK = 100_000


def counter_clockwise(triangles: np.ndarray) -> np.ndarray:
    """The triangles (n, 3, 2) with their vertices ordered counter-clockwise."""
    tri = np.array(triangles, dtype=float)
    a, b, c = tri[:, 0].copy(), tri[:, 1].copy(), tri[:, 2].copy()
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = cross < 0
    tri[flip, 1], tri[flip, 2] = c[flip], b[flip]
    return tri


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """|K| of each triangle (n, 3, 2)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    return 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _clip(poly: np.ndarray, count: np.ndarray, normal: np.ndarray, bound: np.ndarray):
    """Clip each polygon ``poly[p, :count[p]]`` by {x : normal[p]·x ≤ bound[p]}."""
    slots = np.arange(_SLOTS)
    valid = slots[None, :] < count[:, None]
    following = (slots[None, :] + 1) % np.maximum(count, 1)[:, None]
    f = np.einsum("psk,pk->ps", poly, normal) - bound[:, None]
    f_next = np.take_along_axis(f, following, axis=1)
    nxt = np.take_along_axis(poly, following[..., None], axis=1)
    keep = valid & (f <= 0.0)
    cross = valid & ((f <= 0.0) != (f_next <= 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(cross, f / (f - f_next), 0.0)
    point = poly + s[..., None] * (nxt - poly)
    emitted = keep.astype(int) + cross
    start = np.cumsum(emitted, axis=1) - emitted
    out = np.zeros_like(poly)
    rows = np.broadcast_to(np.arange(len(poly))[:, None], keep.shape)
    out[rows[keep], start[keep]] = poly[keep]
    at = start + keep
    out[rows[cross], at[cross]] = point[cross]
    return out, emitted.sum(axis=1)


def _polygon_area(poly: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Shoelace area of each polygon ``poly[p, :count[p]]`` (0 below 3 vertices), about its
    first vertex (no cancellation of the coordinates' magnitude)."""
    poly = poly - poly[:, :1]
    slots = np.arange(_SLOTS)
    valid = slots[None, :] < count[:, None]
    following = (slots[None, :] + 1) % np.maximum(count, 1)[:, None]
    nxt = np.take_along_axis(poly, following[..., None], axis=1)
    cross = poly[..., 0] * nxt[..., 1] - poly[..., 1] * nxt[..., 0]
    area = 0.5 * np.where(valid, cross, 0.0).sum(axis=1)
    return np.where(count >= 3, np.abs(area), 0.0)


def pair_overlaps(subject: np.ndarray, clipper: np.ndarray) -> np.ndarray:
    """|S_p ∩ C_p| for the pairs of counter-clockwise triangles ``subject``, ``clipper``
    (P, 3, 2): S_p clipped by the three half-planes of C_p."""
    out = np.empty(len(subject))
    for lo in range(0, len(subject), _CHUNK):
        s, c = subject[lo:lo + _CHUNK], clipper[lo:lo + _CHUNK]
        poly = np.zeros((len(s), _SLOTS, 2))
        poly[:, :3] = s
        count = np.full(len(s), 3)
        for e in range(3):
            a, b = c[:, e], c[:, (e + 1) % 3]
            normal = np.stack([b[:, 1] - a[:, 1], a[:, 0] - b[:, 0]], axis=1)  # outward
            poly, count = _clip(poly, count, normal, np.einsum("pk,pk->p", normal, a))
        out[lo:lo + _CHUNK] = _polygon_area(poly, count)
    return out


def strip_overlaps(triangles: np.ndarray, width: float, count: int):
    """(cell, strip, |K ∩ S_j|): the overlaps of the triangles (n, 3, 2) with the vertical
    strips S_j = [j width, (j + 1) width] × ℝ, j = 0 … count − 1 (each triangle clipped by
    the two sides of every strip its x-range meets)."""
    tri = counter_clockwise(triangles)
    first = np.clip(np.floor(tri[:, :, 0].min(axis=1) / width).astype(int), 0, count - 1)
    last = np.clip(np.floor(tri[:, :, 0].max(axis=1) / width).astype(int), 0, count - 1)
    spans = last - first + 1
    cell = np.repeat(np.arange(len(tri)), spans)
    strip = first[cell] + np.arange(len(cell)) - np.repeat(np.cumsum(spans) - spans, spans)
    area = np.empty(len(cell))
    for lo in range(0, len(cell), _CHUNK):
        k, j = cell[lo:lo + _CHUNK], strip[lo:lo + _CHUNK]
        poly = np.zeros((len(k), _SLOTS, 2))
        poly[:, :3] = tri[k]
        n = np.full(len(k), 3)
        left = np.where(j > 0, -j * width, np.inf)              # −x ≤ −x_j (none at j = 0)
        right = np.where(j < count - 1, (j + 1) * width, np.inf)  # x ≤ x_{j+1} (none at the end)
        poly, n = _clip(poly, n, np.tile([-1.0, 0.0], (len(k), 1)), left)
        poly, n = _clip(poly, n, np.tile([1.0, 0.0], (len(k), 1)), right)
        area[lo:lo + _CHUNK] = _polygon_area(poly, n)
    return cell, strip, area


def candidate_pairs(old: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, j): the old and new triangles whose bounding boxes overlap (``old`` (n, 3, 2),
    ``new`` (m, 3, 2)), found by one cKDTree per size class of the old triangles."""
    if len(old) == 0 or len(new) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    c_old, c_new = old.mean(axis=1), new.mean(axis=1)
    r_old = np.linalg.norm(old - c_old[:, None], axis=2).max(axis=1)
    r_new = np.linalg.norm(new - c_new[:, None], axis=2).max(axis=1)
    level = np.floor(np.log2(r_old / r_old.max() + 1e-300)).astype(int)
    pairs_i, pairs_j = [], []
    for k in np.unique(level):
        members = np.nonzero(level == k)[0]
        tree = cKDTree(c_old[members])
        hits = tree.query_ball_point(c_new, r_new + r_old[members].max() * (1 + 1e-12),
                                     return_sorted=False)
        lengths = np.fromiter((len(h) for h in hits), int, len(hits))
        if lengths.sum() == 0:
            continue
        pairs_i.append(members[np.concatenate([np.asarray(h, int) for h in hits if h])])
        pairs_j.append(np.repeat(np.arange(len(new)), lengths))
    if not pairs_i:
        return np.zeros(0, int), np.zeros(0, int)
    i, j = np.concatenate(pairs_i), np.concatenate(pairs_j)
    lo_o, hi_o, lo_n, hi_n = old.min(axis=1), old.max(axis=1), new.min(axis=1), new.max(axis=1)
    meet = np.all((lo_o[i] <= hi_n[j]) & (lo_n[j] <= hi_o[i]), axis=1)
    return i[meet], j[meet]


def remap(old: np.ndarray, values: np.ndarray, new: np.ndarray) -> np.ndarray:
    """The cellwise values on the triangles ``new`` (m, 3, 2) of the fields ``values``
    (n,) or (n, k) on the triangles ``old`` (n, 3, 2) of the same region:
    c_j = Σ_i c_i |K_i ∩ T_j| / |T_j| (exact overlaps; conservative)."""
    vals = np.asarray(values, dtype=float)
    flat = vals.ndim == 1
    vals = vals[:, None] if flat else vals
    nonzero = np.any(vals != 0.0, axis=1)
    old_ccw = counter_clockwise(np.asarray(old, dtype=float)[nonzero])
    new_ccw = counter_clockwise(new)
    i, j = candidate_pairs(old_ccw, new_ccw)
    weight = pair_overlaps(old_ccw[i], new_ccw[j])
    out = np.zeros((len(new_ccw), vals.shape[1]))
    kept = vals[nonzero]
    for k in range(vals.shape[1]):
        out[:, k] = np.bincount(j, weights=weight * kept[i, k], minlength=len(new_ccw))
    area = triangle_areas(new_ccw)
    out /= np.where(area > 0, area, 1.0)[:, None]
    return out[:, 0] if flat else out
