"""Boundary surgery (``geometry.surgery``): a fold onto the mass itself, onto the bed, and
the pocket rule (closed below CLOSE_CELLS cells, kept as a hole above)."""

import math

import numpy as np
import pytest

from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.polygon import BoundaryPolygon, polygon_is_simple
from dpcollapse.geometry.surgery import CLOSE_CELLS, bed_contacts, near_contacts, operate, surgery_needed

pytest.importorskip("shapely")


def _densify(corners, tags, h):
    """A polygon through ``corners`` with every edge split into pieces ≤ h (same tag)."""
    pts, out_tags = [], []
    n = len(corners)
    for i in range(n):
        a, b = np.asarray(corners[i], float), np.asarray(corners[(i + 1) % n], float)
        k = max(1, int(math.ceil(np.hypot(*(b - a)) / h - 1e-9)))
        for s in range(k):
            pts.append(a + (b - a) * s / k)
            out_tags.append(tags[i])
    return BoundaryPolygon(np.array(pts), np.array(out_tags))


def _hook(tip_y, pocket_top=0.8, body=1.0, h=0.1):
    """A body [0, body] x [0, 1], a lower block [body, 2] x [0, 0.3] and an arm
    [body, 2] x [pocket_top, 1] whose tip [1.8, 2] x [tip_y, pocket_top] hangs down onto the
    block: the pocket [body, 1.8] x [0.3, pocket_top] is enclosed when the tip touches it."""
    corners = [(0, 0), (2, 0), (2, 0.3), (body, 0.3), (body, pocket_top), (1.8, pocket_top),
               (1.8, tip_y), (2, tip_y), (2, 1), (0, 1)]
    tags = [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL]
    return _densify(corners, tags, h)


def test_no_contact_no_surgery():
    """An open hook (tip 2 h above the block) is left alone."""
    assert operate(_hook(0.5), 0.1) is None


def test_self_contact_keeps_a_large_pocket_as_a_hole():
    """The tip 0.05 h above the block: a near contact; the 0.4 m² pocket (≫ CLOSE_CELLS
    cells) becomes a hole with a free surface; the area grows by the bridged gap only
    (at most the 0.2 m x 0.005 m strip of air under the tip: 6e-4 of the mass)."""
    h = 0.1
    poly = _hook(0.3 + 0.05 * h)
    assert near_contacts(poly.points, poly.edge_tags, h)
    assert surgery_needed(poly, h) == "self-contact"
    result = operate(poly, h)
    assert result is not None and result.near_contacts > 0 and not result.crossings
    # one hole; what else closed are the slivers of air between the bridges in the gap
    assert len(result.holes) == 1 and len(result.kept_pockets) == 1
    assert sum(result.closed_pockets) <= 0.2 * 0.05 * h
    assert 0.8 * 0.5 - 2 * (0.25 * h) ** 2 <= abs(result.holes[0].area) <= 0.8 * 0.5
    assert np.all(result.holes[0].edge_tags == SURFACE)
    gap = 0.25 * h    # the air of the gap strip and a gap² at each end of the contact
    assert 0 <= result.area_change <= 0.2 * 0.05 * h + 2 * gap ** 2   # no mass lost
    assert abs(result.area_change) / result.area_before < 1e-3
    assert polygon_is_simple(result.outer.points)
    # the bed and the wall keep their tags
    assert set(np.unique(result.outer.edge_tags)) == {BED, WALL, SURFACE}


def test_self_contact_closes_a_small_pocket():
    """A pocket of 0.1 x 0.03 m² (below CLOSE_CELLS cells of h = 0.1 m) is closed: no hole,
    its area reported and added."""
    h = 0.1
    poly = _hook(0.3 + 0.05 * h, pocket_top=0.33, body=1.7)
    pocket = 0.1 * 0.03
    assert pocket < CLOSE_CELLS * math.sqrt(3) / 4 * h ** 2
    result = operate(poly, h)
    assert result is not None and not result.holes and result.closed_pockets
    strip = 0.2 * 0.05 * h          # the air of the gap under the tip
    assert pocket <= sum(result.closed_pockets) <= pocket + strip
    assert pocket <= result.area_change <= pocket + strip + 1e-12


def test_crossing_fold_is_united():
    """The tip pushed 0.02 h into the block (the edges cross): the union counts the overlap
    once, keeps the pocket as a hole and the area to 1e-3."""
    h = 0.1
    poly = _hook(0.3 - 0.02 * h)
    assert not polygon_is_simple(poly.points)
    result = operate(poly, h)
    assert result.crossings and len(result.holes) == 1
    overlap = 0.2 * 0.02 * h
    assert result.area_change == pytest.approx(-overlap, abs=0.2 * 0.25 * h * h / 2)
    assert abs(result.area_change) / result.area_before < 1e-3
    assert polygon_is_simple(result.outer.points)


def _nose(tip_y, h=0.05, toe=1.0):
    """A mass on the bed [0, toe] whose front overhangs: the underside rises from the toe
    (toe, 0) to (1.2, 0.2) and comes down to the nose tip (1.6, tip_y)."""
    corners = [(0, 0), (toe, 0), (1.2, 0.2), (1.6, tip_y), (1.7, 0.1), (1.3, 0.5), (0, 0.5)]
    tags = [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL]
    return _densify(corners, tags, h)


def test_nose_above_the_bed_is_no_contact():
    """A nose tip 0.1 h above the bed is left to land by the mesh motion."""
    h = 0.05
    poly = _nose(0.1 * h)
    assert not bed_contacts(poly.points, poly.edge_tags)
    assert operate(poly, h) is None


def test_landed_nose_keeps_a_large_pocket():
    """A landed tip (on y = 0) enclosing a 0.06 m² pocket (≫ a cell) with the bed: the
    pocket stays open (nothing to operate on)."""
    h = 0.05
    poly = _nose(0.0)
    assert bed_contacts(poly.points, poly.edge_tags)
    assert operate(poly, h) is None
    assert surgery_needed(poly, h) is None        # no remesh asked for it either


def test_landed_nose_closes_a_small_pocket():
    """A landed tip whose pocket against the bed is below one cell: closed, the bed runs
    from the wall to the tip, the area grows by the pocket's exactly."""
    h = 0.05
    corners = [(0, 0), (1.55, 0), (1.575, 0.02), (1.6, 0.0), (1.7, 0.1), (1.3, 0.5), (0, 0.5)]
    tags = [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL]
    poly = _densify(corners, tags, h)
    pocket = 0.5 * 0.05 * 0.02
    assert pocket < CLOSE_CELLS * math.sqrt(3) / 4 * h ** 2
    assert surgery_needed(poly, h) == "bed contact"
    result = operate(poly, h)
    assert result is not None and result.bed_contacts == 1 and not result.holes
    assert result.closed_pockets == [pytest.approx(pocket, rel=1e-9)]
    assert result.area_change == pytest.approx(pocket, rel=1e-9)
    outer = result.outer
    bed = outer.edge_tags == BED
    ends = np.roll(outer.points, -1, axis=0)[bed, 0]
    assert outer.points[bed, 0].min() == 0 and ends.max() == 1.6
    assert polygon_is_simple(outer.points)


def _mesh_area(mesh, comm):
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    return comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)


@pytest.mark.mpi
def test_remesh_with_surgery_keeps_a_hole(comm):
    """The hook with its tip 0.05 h above the block, meshed, remeshed with surgery: the new
    mesh has the pocket as a hole (its boundary free surface), one surgery is reported, the
    area grows by the bridged gap only (< 1e-3); a second remesh keeps the hole (chained as a
    second loop) and does no further surgery."""
    from dpcollapse.ale.remesh import remesh_domain
    from dpcollapse.geometry.mesher import boundary_edges, mesh_polygon
    from dpcollapse.geometry.polygon import chain_loops

    h = 0.1
    poly = _hook(0.3 + 0.05 * h)
    tagged = mesh_polygon(comm, poly.points, poly.edge_tags, h)
    area0 = _mesh_area(tagged.mesh, comm)
    done = []
    new, d_area, _ = remesh_domain(tagged, h, None, 1e-9, surgery=True, surgeries=done)
    assert len(done) == 1 and len(done[0].holes) == 1
    area1 = _mesh_area(new.mesh, comm)
    assert area1 == pytest.approx(area0 + d_area, rel=1e-9)
    assert 0 < (area1 - area0) / area0 < 1e-3
    edges, tags = boundary_edges(new)
    if comm.rank == 0:
        loops = chain_loops(edges, tags)
        assert len(loops) == 2 and np.all(loops[1].edge_tags == SURFACE)
    again, _, _ = remesh_domain(new, h, None, 1e-9, surgery=True, surgeries=done)
    assert len(done) == 1
    assert _mesh_area(again.mesh, comm) == pytest.approx(area1, rel=1e-9)


def test_a_mass_that_would_come_apart_is_an_error():
    """A figure eight (a fold that pinches the mass into two lobes meeting at a point): the
    union is two pieces; the surgery refuses (ValueError: exit 4 at the remesh), it never
    drops one."""
    h = 0.1
    corners = [(0, 0), (1, 0), (2, 1), (3, 1), (3, 0), (2, 0), (1, 1), (0, 1)]
    poly = _densify(corners, [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL], h)
    with pytest.raises(ValueError, match="pieces"):
        operate(poly, h)
