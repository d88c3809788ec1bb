"""The landing of a nose's underside at remeshes (``ale.remesh.repair_polygon`` (iii), issue 49:
the a = 10 no-slip column at L0/20, exit 3 at t = 0.256 s). The nose's front face stood
near-vertical, its vertices' x wandering by micrometres, so some of its edges ran right (an
"underside") and some left; every vertex with both edges running right and lower than the trim
thickness δ was put on the bed, one by one — the face became a spike 4.8 mm high and 31 µm
wide with three bed/free-surface corners within 50 µm at its foot. Its cells, 0.1 mm, carried a
sub-cell lip on which the fixed point did not converge at any Δt (the largest update of every
iteration there, up to 200 m/s). The underside now lands as one run that starts at the bed:
from the toe, the vertices in a row that run right below δ."""

from __future__ import annotations

import numpy as np

from dpcollapse.ale.remesh import repair_polygon
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.polygon import BoundaryPolygon, polygon_is_simple

DELTA = 5.86075e-3    # δ: one grain of the a = 10 column (> 0.2 ΔX = 1 mm)

#: the nose of that run at its remesh 11 (t = 0.2562 s) [m], from the toe on the bed
NOSE = [
    (0.340423, 0.000000), (0.344163, 0.001335), (0.344968, 0.001799), (0.345662, 0.002280),
    (0.345851, 0.002598), (0.345905, 0.002951), (0.345948, 0.003372), (0.345983, 0.003831),
    (0.346002, 0.004314), (0.346001, 0.004795), (0.346014, 0.005267), (0.346032, 0.005739),
    (0.346045, 0.006204), (0.346051, 0.006636), (0.345822, 0.006763), (0.345374, 0.007176),
    (0.344973, 0.007549), (0.344586, 0.007908), (0.344204, 0.008259), (0.343829, 0.008603),
    (0.343459, 0.008940), (0.343093, 0.009271), (0.342731, 0.009594), (0.342374, 0.009911),
    (0.342022, 0.010220), (0.341680, 0.010521), (0.341345, 0.010809), (0.340968, 0.011079),
]


def _column_with_nose() -> BoundaryPolygon:
    """The mass on the bed (wall x = 0) ending in NOSE, its top falling to it, CCW."""
    bed = [(x, 0.0) for x in np.linspace(0.0, 0.335, 68)]
    top = [(0.30, 0.04), (0.20, 0.10), (0.10, 0.16), (0.0, 0.20)]
    points = np.array(bed + NOSE + top + [(0.0, 0.10)], dtype=float)
    tags = np.array([BED] * len(bed) + [SURFACE] * (len(NOSE) + len(top) - 1) + [WALL] * 2)
    return BoundaryPolygon(points, tags)


def _angles(points: np.ndarray) -> np.ndarray:
    a, b = np.roll(points, 1, axis=0) - points, np.roll(points, -1, axis=0) - points
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def test_a_near_vertical_nose_face_lands_without_a_spike():
    repaired = repair_polygon(_column_with_nose(), DELTA)
    pts, tags = repaired.points, repaired.edge_tags
    assert polygon_is_simple(pts)
    nose = pts[:, 0] > 0.339
    # the underside below the face's first left-running edge is on the bed (the nose landed)
    assert np.all(pts[nose & (pts[:, 0] < 0.34598) & (pts[:, 1] < DELTA), 1] == 0.0)
    # no spike: every angle of the repaired nose above the spike criterion (15°)
    assert _angles(pts)[nose].min() > 15.0
    # one toe: a single bed → free-surface corner
    corners = np.flatnonzero((tags == SURFACE) & (np.roll(tags, 1) == BED))
    assert len(corners) == 1
