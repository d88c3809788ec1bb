"""The surgery's notch rule (``geometry.surgery.notch_contacts``, issue 52's a = 10 cylinder):
a breaking front leaning over a thin nose, a V of air reaching down to a neck far thinner
than the cells; the surgery closes the neck onto the bed and keeps the area."""

import math

import numpy as np
import pytest

from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.polygon import polygon_is_simple
from dpcollapse.geometry.surgery import CONTACT_GAP, notch_contacts, operate, surgery_needed
from tests.unit.test_surgery import _densify

pytest.importorskip("shapely")

H = 0.1                 # the mesh size [m]
NECK = 0.01 * H         # the neck under the notch's bottom (a = 10: 0.08 mm at ΔX = 7.5 mm)


def _notch(neck=NECK, face_angle=70.0):
    """A mass [0, 2] x [0, 0.3] on the bed, its front face rising at ``face_angle`` (leaning
    over the nose) from the notch's bottom (1.9, neck), and a nose 0.2 H thick from there to
    the toe (2.3, 0), its top coming down into the notch: a V of air reaching to ``neck``
    above the bed, 2 h behind the toe."""
    c, s = math.cos(math.radians(face_angle)), math.sin(math.radians(face_angle))
    top = 0.3
    lean = (top - neck) * c / s
    corners = [(0, 0), (2.3, 0), (2.3, 0.2 * H), (1.92, 0.2 * H), (1.9, neck),
               (1.9 + lean, top), (0, top)]
    tags = [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL]
    return _densify(corners, tags, H / 3)   # the face's first vertex 0.31 H up (> g)


def _lowest_behind_toe(poly):
    """The lowest free-surface vertex behind the toe (above the bed, not on it)."""
    pts, tags = poly.points, poly.edge_tags
    surf = (tags == SURFACE) & (np.roll(tags, 1) == SURFACE) & (pts[:, 1] > 0)
    return pts[surf & (pts[:, 0] < 2.3 - 1e-9), 1].min()


def test_the_notch_is_a_contact():
    poly = _notch()
    found = notch_contacts(poly.points, poly.edge_tags, H)
    assert len(found) == 1
    k, _ = found[0]
    assert tuple(poly.points[k]) == pytest.approx((1.9, NECK))
    assert surgery_needed(poly, H) == "notch"


def test_the_surgery_closes_the_neck_and_keeps_the_area():
    """The notch's bottom filled: the lowest free-surface vertex behind the toe rises from
    0.01 H to ≥ half the nose (0.1 H); nothing is cut (the toe and the nose stay), the area
    grows by the filled V only (≤ g², < 1e-3 of the mass)."""
    poly = _notch()
    assert _lowest_behind_toe(poly) == pytest.approx(NECK)
    result = operate(poly, H)
    assert result is not None and result.notches == 1 and not result.crossings
    assert not result.holes
    outer = result.outer
    assert polygon_is_simple(outer.points)
    assert outer.points[:, 0].max() == pytest.approx(2.3, abs=1e-12)      # the toe kept
    assert _lowest_behind_toe(outer) >= 0.1 * H
    gap = CONTACT_GAP * H
    assert 0 < result.area_change <= gap ** 2
    assert result.area_change / result.area_before < 1e-3
    assert not notch_contacts(outer.points, outer.edge_tags, H)        # done in one surgery
    assert set(np.unique(outer.edge_tags)) == {BED, WALL, SURFACE}


def test_a_shallow_dip_of_a_thin_film_is_no_notch():
    """A film 0.2 H thick whose surface dips to 0.15 H (thinner than g, but not a V to the
    bed) is left alone, as is an open front whose face reaches the bed at the toe."""
    corners = [(0, 0), (2.3, 0), (2.3, 0.2 * H), (2.1, 0.2 * H), (2.0, 0.15 * H),
               (1.9, 0.2 * H), (1.8, 0.3), (0, 0.3)]
    tags = [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL]
    film = _densify(corners, tags, H / 4)
    assert not notch_contacts(film.points, film.edge_tags, H)
    assert operate(film, H) is None
    assert operate(_notch(neck=0.5 * H), H) is None          # a notch 2 g above the bed


def _mesh_area(mesh, comm):
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    return comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)


@pytest.mark.mpi
def test_remesh_closes_the_notch_and_keeps_the_area(comm):
    """The notched mass meshed (its neck's cells: < 2°), then remeshed with the runs'
    resampling budget: without surgery the neck stays (< 2° again); with surgery and the
    area put back, one surgery (a notch), the smallest angle ≥ 5 times the neck's, the area
    kept to 1e-9."""
    from dpcollapse.ale.motion import quality
    from dpcollapse.ale.remesh import remesh_domain
    from dpcollapse.domain.moving import MIN_ANGLE_FLOOR, REMESH_AREA_TOLERANCE_CONSERVED
    from dpcollapse.geometry.mesher import mesh_polygon

    poly = _notch()
    tagged = mesh_polygon(comm, poly.points, poly.edge_tags, H)
    before = quality(tagged.mesh)["min_angle"]
    assert before < 2.0
    area0 = _mesh_area(tagged.mesh, comm)
    budget = REMESH_AREA_TOLERANCE_CONSERVED * area0
    plain, _, _ = remesh_domain(tagged, H, None, budget, conserve_area=True)
    assert quality(plain.mesh)["min_angle"] < 2.0
    done = []
    new, _, _ = remesh_domain(tagged, H, None, budget, surgery=True, surgeries=done,
                              conserve_area=True)
    assert len(done) == 1 and done[0].notches == 1
    after = quality(new.mesh)["min_angle"]
    assert after > max(MIN_ANGLE_FLOOR, 5 * before)
    assert _mesh_area(new.mesh, comm) == pytest.approx(area0, rel=1e-9)
