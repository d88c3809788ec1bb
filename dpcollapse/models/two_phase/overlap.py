"""Exact cell overlap fractions c_K = |K ∩ P| / |K| of triangles K with convex polygons P
(the initial volume fractions of the two-phase model).

Each triangle is clipped against the half-planes of P, one after another (Sutherland–Hodgman),
and the clipped polygon's area taken by the shoelace formula. A half-plane is (n, d):
{x : n·x ≤ d}. A convex polygon given counter-clockwise is the intersection of the half-planes
left of its edges; the rectangle [lower, upper] is the four half-planes x ≥ x_l, x ≤ x_u,
y ≥ y_l, y ≤ y_u (clipped in that order). The union of convex polygons that only touch along
edges has the sum of their overlaps.

Axisymmetric (``radial=True``, issue 52): the fractions of the body of revolution's volume,
c_K = ∫_{K ∩ P} r dA / ∫_K r dA, the first moment ∫ x dA = (1/6) Σ_i (x_i + x_{i+1})
(x_i y_{i+1} − x_{i+1} y_i) of the clipped polygon over the triangle's (exact as well).
"""

from __future__ import annotations

import numpy as np


def _clip(poly: list, normal, bound: float) -> list:
    """The part of the polygon ``poly`` (list of (x, y)) where normal·x ≤ bound."""
    nx, ny = normal
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        fa, fb = nx * a[0] + ny * a[1], nx * b[0] + ny * b[1]
        ina, inb = fa <= bound, fb <= bound
        if ina:
            out.append(a)
        if ina != inb:
            s = (bound - fa) / (fb - fa)
            out.append((a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])))
    return out


def _area(poly) -> float:
    """|poly| by the shoelace formula (0 for fewer than 3 vertices)."""
    if len(poly) < 3:
        return 0.0
    p = np.asarray(poly)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _radial_moment(poly) -> float:
    """∫_poly x dA (x = r ≥ 0: the volume of its body of revolution over 2π; 0 for fewer than
    3 vertices), the absolute value (either orientation)."""
    if len(poly) < 3:
        return 0.0
    p = np.asarray(poly)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    return abs(float(np.dot(x + xn, x * yn - xn * y))) / 6.0


def polygon_halfplanes(points) -> list:
    """The half-planes (n, d) of the convex polygon ``points`` (m, 2), counter-clockwise:
    n the outward normal of each edge (zero-length edges skipped)."""
    p = np.asarray(points, dtype=float)
    planes = []
    for a, b in zip(p, np.roll(p, -1, axis=0)):
        tx, ty = b - a
        if tx == 0.0 and ty == 0.0:
            continue
        normal = (float(ty), float(-tx))
        planes.append((normal, normal[0] * a[0] + normal[1] * a[1]))
    return planes


def halfplane_fraction(triangles: np.ndarray, planes: list, box, radial: bool = False) -> np.ndarray:
    """|K ∩ ∩_i {n_i·x ≤ d_i}| / |K| for each triangle K of ``triangles`` (n, 3, 2); ``box``
    ((x0, y0), (x1, y1)) bounds the intersection (triangles outside it get 0 unclipped);
    ``radial``: the measure r dA instead of dA (axisymmetric)."""
    measure = _radial_moment if radial else _area
    tri = np.asarray(triangles, dtype=float)
    out = np.zeros(len(tri))
    (x0, y0), (x1, y1) = box
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    near = (hi[:, 0] >= x0) & (lo[:, 0] <= x1) & (hi[:, 1] >= y0) & (lo[:, 1] <= y1)
    for k in np.nonzero(near)[0]:
        poly = [tuple(p) for p in tri[k]]
        for normal, bound in planes:
            poly = _clip(poly, normal, bound)
            if not poly:
                break
        whole = measure(tri[k])
        out[k] = measure(poly) / whole if whole > 0 else 0.0
    return np.clip(out, 0.0, 1.0)


def rectangle_fraction(triangles: np.ndarray, lower, upper) -> np.ndarray:
    """|K ∩ R| / |K| for the rectangle R = [lower, upper] (exact up to round-off)."""
    planes = [((-1.0, 0.0), -lower[0]), ((1.0, 0.0), upper[0]),
              ((0.0, -1.0), -lower[1]), ((0.0, 1.0), upper[1])]
    return halfplane_fraction(triangles, planes, (lower, upper))


def polygon_fraction(triangles: np.ndarray, points, radial: bool = False) -> np.ndarray:
    """|K ∩ P| / |K| for the convex polygon P = ``points`` (m, 2), counter-clockwise
    (``radial``: in the measure r dA)."""
    p = np.asarray(points, dtype=float)
    return halfplane_fraction(triangles, polygon_halfplanes(p), (p.min(axis=0), p.max(axis=0)),
                              radial)


def union_fraction(triangles: np.ndarray, polygons, radial: bool = False) -> np.ndarray:
    """|K ∩ ∪ P_j| / |K| for convex polygons P_j that overlap at most along edges: the sum
    of their fractions (clipped to 1 against round-off; ``radial``: in the measure r dA)."""
    total = np.zeros(len(triangles))
    for points in polygons:
        total += polygon_fraction(triangles, points, radial)
    return np.minimum(total, 1.0)
