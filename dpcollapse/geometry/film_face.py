"""The film trim's cut face at the angle of repose (issue 49; pure numpy).

The film trim (``ale.remesh.repair_polygon``) cuts the front film thinner than δ ahead of
x_δ, the furthest x where the mass is at least δ thick. Cut by the vertical x = x_δ, the
mass keeps a face δ high that slumps again after every trim (a μ(I) face steeper than μ_s
flows). ``cut_at_repose`` cuts along a face of slope μ_r instead: it removes from the
polygon the wedge

    W = {x > x_δ} ∩ {y − y_a > −μ_r (x − x_δ)},   apex a = (x_δ, y_a), y_a = y_low(x_δ) + δ,

so the mass kept ahead of x_δ lies under the line through a descending at slope μ_r to
the bed at x_δ + δ/μ_r. A thin layer whose surface slopes by |∂h/∂x| carries a shear
stress |τ| = |∂h/∂x| p (long-wave balance), so a face at μ_r = min(μ_s, μ_b) is at the
yield of the material and of a Coulomb bed: it does not slump. Everything the vertical cut
keeps is kept (W lies in x > x_δ), and the cut is idempotent (a mass already under the
line loses nothing).
"""

from __future__ import annotations

import numpy as np

#: Distance [m] by which a point must be inside the wedge to count as inside: a point on
#: its rays up to round-off (the face of an earlier cut) is outside, so a second cut of a
#: cut polygon removes nothing.
RAY_TOLERANCE = 1e-12


def lowest_point_at(points: np.ndarray, x: float) -> float:
    """The lowest y where the closed polygon ``points`` meets the vertical line at ``x``
    (its edges' crossings and vertices on it); +inf when it does not."""
    p = np.asarray(points, dtype=float)
    q = np.roll(p, -1, axis=0)
    ys = list(p[p[:, 0] == x, 1])
    span = (p[:, 0] - x) * (q[:, 0] - x) < 0
    if span.any():
        a, b = p[span], q[span]
        ys.extend(a[:, 1] + (x - a[:, 0]) / (b[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    return float(min(ys)) if ys else np.inf


def _inside(p: np.ndarray, apex: np.ndarray, slope: float) -> np.ndarray:
    """Inside the wedge W by more than ``RAY_TOLERANCE`` (points on its rays are outside)."""
    d = p - apex
    return (d[..., 0] > RAY_TOLERANCE) & (d[..., 1] + slope * d[..., 0] > RAY_TOLERANCE)


def _interval(a: np.ndarray, b: np.ndarray, apex: np.ndarray, slope: float):
    """The part (t_in, t_out) of the segment a + t (b − a), t ∈ [0, 1], inside W, with the
    ray each end lies on (0: the vertical ray, 1: the sloped one; −1: the segment's own
    end), or None (Cyrus–Beck against W's two half-planes n_k·(p − apex) > ``RAY_TOLERANCE``,
    the same test as ``_inside``)."""
    t_in, t_out, ray_in, ray_out = 0.0, 1.0, -1, -1
    for k, n in enumerate((np.array([1.0, 0.0]), np.array([slope, 1.0]))):
        g0, g1 = float(n @ (a - apex)) - RAY_TOLERANCE, float(n @ (b - a))
        if g1 == 0.0:
            if g0 <= 0.0:
                return None
        elif g1 > 0.0:                 # entering where g0 + t g1 = 0
            t = -g0 / g1
            if t >= t_in:
                t_in, ray_in = t, k
        else:                          # leaving
            t = -g0 / g1
            if t <= t_out:
                t_out, ray_out = t, k
    if t_out <= t_in:
        return None
    return t_in, t_out, ray_in, ray_out


def cut_at_repose(points: np.ndarray, edge_tags: np.ndarray, x_cut: float, thickness: float,
                  slope: float, cut_tag: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The closed CCW polygon (``points``, ``edge_tags``) without the wedge W ahead of
    ``x_cut`` = x_δ above the line of slope −``slope`` = −μ_r through the apex
    (x_δ, y_low(x_δ) + ``thickness``) (module docstring). Kept pieces of edges keep their
    tags; the new edges along W's rays get ``cut_tag``. Returns (points, tags), or None when
    nothing of the polygon lies at x_δ or no vertex lies outside W; the caller checks that
    the result is simple."""
    pts = np.asarray(points, dtype=float)
    tags = np.asarray(edge_tags, dtype=np.int64)
    y_low = lowest_point_at(pts, x_cut)
    if not np.isfinite(y_low) or slope <= 0:
        return None
    apex = np.array([x_cut, y_low + thickness])
    inside = _inside(pts, apex, slope)
    if inside.all():
        return None
    start = int(np.argmin(inside))               # a vertex outside W
    pts, tags, inside = (np.roll(pts, -start, axis=0), np.roll(tags, -start),
                         np.roll(inside, -start))
    n = len(pts)
    out, out_tags = [], []
    ray_entered = -1
    for i in range(n):
        a, b, tag = pts[i], pts[(i + 1) % n], int(tags[i])
        if not inside[i]:
            out.append(a)
            out_tags.append(tag)
        piece = _interval(a, b, apex, slope)
        if piece is None:
            continue
        t_in, t_out, ray_in, ray_out = piece
        if not inside[i]:                        # the edge enters W at e
            out.append(a + t_in * (b - a))
            out_tags.append(cut_tag)
            ray_entered = ray_in
        if t_out < 1.0 or not inside[(i + 1) % n]:   # ... and leaves it at f
            if ray_out != ray_entered:           # along W's boundary, through the apex
                out.append(apex.copy())
                out_tags.append(cut_tag)
            out.append(a + t_out * (b - a))
            out_tags.append(tag)
    p_out, t_out_tags = np.array(out), np.array(out_tags, dtype=np.int64)
    same = np.all(p_out == np.roll(p_out, -1, axis=0), axis=1)
    return p_out[~same], t_out_tags[~same]
