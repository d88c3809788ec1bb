"""Boundary chaining and resampling (pure numpy, no dolfinx)."""

import numpy as np
import pytest

from dpcollapse.geometry.polygon import BoundaryPolygon, chain_boundary, polygon_is_simple, resample

BED, WALL, SURFACE = 1, 2, 3
TRAPEZOID = np.array([[0.0, 0.0], [0.297, 0.0], [0.206, 0.25], [0.0, 0.25]])


def _edges_of(points, tags, closed=True):
    """Edges (m, 2, 2) and tags of a polyline/loop given by its vertices."""
    pts = np.asarray(points, dtype=float)
    b = np.roll(pts, -1, axis=0)
    edges = np.stack([pts, b], axis=1)
    tags = np.asarray(tags)
    return (edges, tags) if closed else (edges[:-1], tags[:-1])


def _subdivided_trapezoid():
    """Trapezoid boundary with every side cut into several pieces; CW on purpose."""
    pts, tags = [], []
    sides = [(TRAPEZOID[0], TRAPEZOID[3], 4, WALL), (TRAPEZOID[3], TRAPEZOID[2], 3, SURFACE),
             (TRAPEZOID[2], TRAPEZOID[1], 5, SURFACE), (TRAPEZOID[1], TRAPEZOID[0], 6, BED)]
    for a, b, k, t in sides:
        for s in range(k):
            pts.append(a + (b - a) * (s / k))
            tags.append(t)
    return _edges_of(pts, tags)


def _loop_area(points):
    x, y = points[:, 0], points[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def test_chain_trapezoid_shuffled_duplicated_reversed():
    rng = np.random.default_rng(0)
    edges, tags = _subdivided_trapezoid()
    m = len(edges)
    flip = rng.random(m) < 0.5
    edges[flip] = edges[flip][:, ::-1]
    dup = rng.choice(m, size=6, replace=False)
    edges = np.concatenate([edges, edges[dup][:, ::-1]])
    tags = np.concatenate([tags, tags[dup]])
    perm = rng.permutation(len(edges))
    poly = chain_boundary(edges[perm], tags[perm])

    assert len(poly) == m
    assert poly.area == pytest.approx((0.297 + 0.206) * 0.25 / 2, abs=1e-12)  # 0.062875
    assert poly.area > 0
    # starts at a corner, the lowest-leftmost one: (0, 0), leaving along the bed
    assert poly.points[0].tolist() == [0.0, 0.0] and poly.edge_tags[0] == BED
    corner_pts = {tuple(p) for p in poly.points[poly.corners]}
    assert corner_pts == {(0.0, 0.0), (0.297, 0.0), (0.0, 0.25)}
    # each edge's tag is the tag of that segment of the trapezoid
    mid = 0.5 * (poly.points + np.roll(poly.points, -1, axis=0))
    expect = np.where(np.isclose(mid[:, 1], 0), BED, np.where(np.isclose(mid[:, 0], 0), WALL,
                                                              SURFACE))
    assert np.array_equal(poly.edge_tags, expect)
    segs = poly.segments()
    assert [t for t, _ in segs] == [BED, SURFACE, WALL]
    assert [len(i) for _, i in segs] == [7, 9, 5]
    assert segs[0][1][0] == 0 and segs[-1][1][-1] == 0
    assert poly.min_edge_length == pytest.approx(0.297 / 6)
    assert polygon_is_simple(poly.points)


def test_chain_rejects_bad_loops():
    edges, tags = _subdivided_trapezoid()
    with pytest.raises(ValueError, match="degree"):  # open chain
        chain_boundary(edges[1:], tags[1:])
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    e1, t1 = _edges_of(sq, [1] * 4)
    e2, t2 = _edges_of(sq + 1.0, [1] * 4)  # shares vertex (1, 1): figure-eight
    with pytest.raises(ValueError, match="degree"):
        chain_boundary(np.concatenate([e1, e2]), np.concatenate([t1, t2]))
    e3, t3 = _edges_of(sq + 3.0, [1] * 4)  # two disjoint loops
    with pytest.raises(ValueError, match="2 closed loops"):
        chain_boundary(np.concatenate([e1, e3]), np.concatenate([t1, t3]))
    bow, tb = _edges_of([[0, 0], [1, 1], [1, 0], [0, 1]], [1] * 4)  # crossing, not at a vertex
    with pytest.raises(ValueError, match="intersects"):
        chain_boundary(bow, tb)
    bad_tags = tags.copy()
    with pytest.raises(ValueError, match="conflicting"):
        chain_boundary(np.concatenate([edges, edges[:1]]), np.concatenate([bad_tags, [9]]))


def test_polygon_is_simple():
    assert polygon_is_simple([[0, 0], [1, 0], [1, 1], [0, 1]])
    assert not polygon_is_simple([[0, 0], [1, 1], [1, 0], [0, 1]])
    # a vertex touching a non-adjacent edge
    assert not polygon_is_simple([[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]])
    # a spike folding back on its incoming edge
    assert not polygon_is_simple([[0, 0], [2, 0], [1, 0], [1, 1]])


def _wavy_domain(n_surface=1500, seed=1):
    """Bed (few points), right wall, densely and unevenly sampled wavy surface, left wall
    as one long edge."""
    rng = np.random.default_rng(seed)
    h = lambda x: 0.3 + 0.02 * np.sin(20 * x) + 0.004 * np.sin(90 * x)  # noqa: E731
    bed = np.column_stack([np.linspace(0, 1, 6)[:-1], np.zeros(5)])
    right = np.array([[1.0, 0.0], [1.0, 0.5 * h(1.0)]])
    s = np.sort(rng.random(n_surface - 2)) ** 2  # clustered near x = 1
    xs = np.concatenate([[1.0], 1.0 - s, [0.0]])
    surf = np.column_stack([xs, h(xs)])
    pts = np.concatenate([bed, right, surf])
    tags = np.array([BED] * 5 + [WALL] * 2 + [SURFACE] * (n_surface - 1) + [WALL])
    return BoundaryPolygon(pts, tags)


def _on_original_edges(new_pts, old_pts, tol=1e-12):
    """Each new point is an old point exactly or lies on some old edge (collinear, inside)."""
    a, b = old_pts, np.roll(old_pts, -1, axis=0)
    ok = []
    for p in new_pts:
        if np.any(np.all(old_pts == p, axis=1)):
            ok.append(True)
            continue
        ab, ap = b - a, p - a
        cross = ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0]
        t = (ab * ap).sum(1) / (ab * ab).sum(1)
        L = np.linalg.norm(ab, axis=1)
        ok.append(bool(np.any((np.abs(cross) <= tol * L) & (t >= 0) & (t <= 1))))
    return np.array(ok)


def test_resample_wavy_surface():
    poly = _wavy_domain()
    target, budget = 0.02, 2e-5
    new, dA = resample(poly, target, budget)

    old_corners = poly.points[poly.corners]
    assert np.array_equal(new.points[new.corners], old_corners)  # bitwise, same order
    assert np.array_equal(new.edge_tags[new.corners], poly.edge_tags[poly.corners])
    assert abs(dA) <= budget
    assert dA == pytest.approx(new.area - poly.area, abs=1e-15)
    assert _on_original_edges(new.points, poly.points).all()
    assert new.edge_lengths.max() <= 1.5 * target
    assert polygon_is_simple(new.points)
    # it actually coarsened the clustered surface and split the long wall edge
    assert len(new) < len(poly) / 4
    assert new.min_edge_length > 10 * poly.min_edge_length
    wall = new.points[np.isclose(new.points[:, 0], 0.0)]
    assert len(wall) >= 0.3 / target


def test_resample_zero_budget_only_drops_collinear_points():
    poly = _wavy_domain(n_surface=300)
    tags = poly.edge_tags.copy()
    tags[2:5] = 4  # the bed changes tag at (0.4, 0): a corner on a straight line
    poly = BoundaryPolygon(poly.points, tags)
    new, dA = resample(poly, 2.0, 0.0)
    assert dA == pytest.approx(0.0, abs=1e-13)
    surface_old = poly.points[poly.edge_tags == SURFACE]
    kept = (new.points[:, None, :] == surface_old[None]).all(-1).any(0)
    assert kept.all()  # no curved surface point may go
    bed = new.points[new.points[:, 1] == 0.0]
    assert bed.tolist() == [[0.0, 0.0], [0.4, 0.0], [1.0, 0.0]]  # corners only, in order


def test_resample_never_merges_beyond_target():
    # dense square, every original edge short: coarsening must stop at the target size,
    # so nothing has to be inserted and every vertex is an original one
    t = np.linspace(0, 1, 201)[:-1]
    sq = np.concatenate([np.column_stack([t, 0 * t]), np.column_stack([1 + 0 * t, t]),
                         np.column_stack([1 - t, 1 + 0 * t]), np.column_stack([0 * t, 1 - t])])
    poly = BoundaryPolygon(sq, np.repeat([BED, WALL, SURFACE, WALL], 200))
    new, dA = resample(poly, 0.1, 1.0)
    assert (new.points[:, None, :] == poly.points[None]).all(-1).any(1).all()
    assert new.edge_lengths.max() <= 0.1 and len(new) >= 40
    assert abs(dA) <= 1e-14


def test_resample_callable_target_and_fixed_points():
    poly = _wavy_domain(n_surface=600)
    fixed = [300, 301, 450]
    new, _ = resample(poly, lambda t: 0.05 if t == SURFACE else 0.01, 1e-4, fixed=fixed)
    for i in fixed:
        assert np.any(np.all(new.points == poly.points[i], axis=1))
    L, t = new.edge_lengths, new.edge_tags
    assert L[t == WALL].max() <= 0.015 and L[t == SURFACE].max() <= 0.075


def test_resample_toe_wedge_keeps_toe():
    # bed (0,0)->(1,0); toe at (1,0); surface creeps back over the bed at tiny heights
    s = np.linspace(0, 1, 400)[1:]
    surf_x = 1.0 - 0.3 * s ** 3
    surf_y = 1e-6 * s + 1e-3 * s ** 4
    top = np.array([[0.5, 0.2], [0.0, 0.2]])
    pts = np.concatenate([[[0.0, 0.0], [1.0, 0.0]], np.column_stack([surf_x, surf_y]), top])
    tags = np.array([BED] + [SURFACE] * (len(pts) - 2) + [WALL])
    poly = BoundaryPolygon(pts, tags)
    assert polygon_is_simple(poly.points)
    new, dA = resample(poly, 0.05, 1e-5)
    toe = [i for i in new.corners if new.points[i].tolist() == [1.0, 0.0]]  # exactly
    assert len(toe) == 1
    assert new.edge_tags[toe[0] - 1] == BED and new.edge_tags[toe[0]] == SURFACE
    assert polygon_is_simple(new.points)
    assert np.all(new.points[new.edge_tags == SURFACE][1:, 1] > 0)  # surface above bed
    assert abs(dA) <= 1e-5
    assert len(new) < len(poly) / 4


def test_resample_keeps_vertex_whose_removal_would_self_intersect():
    # a thin slit from the bed pokes up into a tiny bump of the surface: removing the bump
    # vertex costs almost no area but would put the slit's tip outside the polygon
    bump = [0.5, 1.001]
    surface = [[1.0, 1.0]] + [[x, 1.0] for x in np.linspace(0.9, 0.6, 4)] + [bump] + \
              [[x, 1.0] for x in np.linspace(0.4, 0.1, 4)] + [[0.0, 1.0]]
    pts = [[0.0, 0.0], [0.499, 0.0], [0.5, 1.0005], [0.501, 0.0], [1.0, 0.0]] + surface
    tags = [BED, WALL, WALL, BED, WALL] + [SURFACE] * (len(surface) - 1) + [WALL]
    poly = BoundaryPolygon(pts, tags)
    assert polygon_is_simple(poly.points)
    new, dA = resample(poly, 2.0, 1e-3, fixed=[2])
    assert polygon_is_simple(new.points)
    assert any(p.tolist() == bump for p in new.points)
    assert len(new) == 8  # all collinear surface points went, the bump stayed


def test_untangle_cuts_fold_at_crossing():
    """A square whose top edge has a spike folded back across it: the spike's loop is cut
    off at the crossing and the area change is minus the loop's signed area."""
    from dpcollapse.geometry.polygon import untangle

    # top runs right to left; (0.3, 1.2) -> (0.8, 0.9) crosses the edge (1, 1) -> (0.6, 1)
    pts = np.array([[0, 0], [1, 0], [1, 1], [0.6, 1], [0.3, 1.2], [0.8, 0.9], [0.2, 1], [0, 1]],
                   dtype=float)
    tags = np.array([1, 3, 3, 3, 3, 3, 3, 2])
    assert not polygon_is_simple(pts)
    out, out_tags, d_area = untangle(pts, tags, fixed=[0, 1, 7])
    assert polygon_is_simple(out)
    assert len(out) == len(out_tags)
    area = 0.5 * np.sum(out[:, 0] * np.roll(out[:, 1], -1) - np.roll(out[:, 0], -1) * out[:, 1])
    before = 0.5 * np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
    assert d_area == pytest.approx(area - before)
    for corner in ([0, 0], [1, 0], [0, 1]):
        assert any(np.allclose(p, corner) for p in out)
    # nothing to do on a simple polygon
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    same, _, zero = untangle(sq, np.array([1, 3, 3, 2]))
    assert np.array_equal(same, sq) and zero == 0


def test_clip_right_and_offset_run():
    from dpcollapse.geometry.polygon import clip_right, offset_run

    pts = np.array([[0, 0], [2, 0], [2, 0.1], [0, 1]], dtype=float)
    tags = np.array([1, 3, 3, 2])
    out, out_tags = clip_right(pts, tags, 1.0, 3)
    assert out.tolist() == [[0, 0], [1, 0], [1, 0.55], [0, 1]]
    assert out_tags.tolist() == [1, 3, 3, 2]
    # put back 0.1 of area by moving the surface's interior vertices: exact to round-off
    sq = np.array([[0, 0], [1, 0], [1, 1], [0.5, 1], [0, 1]], dtype=float)
    moved = offset_run(sq, np.array([1, 3, 3, 3, 2]), 3, 0.1)
    area = 0.5 * np.sum(moved[:, 0] * np.roll(moved[:, 1], -1) - np.roll(moved[:, 0], -1) * moved[:, 1])
    assert area == pytest.approx(1.1, rel=1e-12)
    assert np.array_equal(moved[[0, 1, 4]], sq[[0, 1, 4]])    # corners stay
    assert moved[3, 1] > 1.0


def test_remove_spikes_drops_a_hairpin():
    """A thin spike on the top edge (interior angle ~2°) goes; the square's corners stay."""
    from dpcollapse.geometry.polygon import remove_spikes

    pts = np.array([[0, 0], [1, 0], [1, 1], [0.51, 1], [0.5, 1.3], [0.49, 1], [0, 1]], dtype=float)
    tags = np.array([1, 3, 3, 3, 3, 3, 2])
    out, out_tags = remove_spikes(pts, tags, 3, 15.0)
    assert [0.5, 1.3] not in out.tolist()
    assert len(out) == 6 and len(out_tags) == 6 and polygon_is_simple(out)
    same, _ = remove_spikes(out, out_tags, 3, 15.0)
    assert np.array_equal(same, out)
