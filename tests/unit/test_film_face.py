"""The film trim's cut face at the angle of repose (``numerics.remesh_film_trim_face``,
issue 49: the a = 0.5 column's vertical cut face slumped again after every trim and the
run never came to rest). The face descends from δ above the foot at x_δ to the bed at
slope μ_r = min(μ_s, μ_b); the film under that line (a deposit that does not flow) is kept.
Only where the front is slower than √(g δ): a flowing front is cut vertically."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.ale.remesh import repair_polygon
from dpcollapse.config import config_to_dict, from_saved, load_config, validate_config
from dpcollapse.domain.base import film_face_slope, film_face_speed, film_trim_thickness
from dpcollapse.domain.moving import MovingDomain
from dpcollapse.errors import ConfigError
from dpcollapse.geometry.mesher import BED, SURFACE, WALL, mesh_polygon
from dpcollapse.geometry.polygon import BoundaryPolygon, polygon_is_simple, signed_area
from tests.helpers import ROOT

COLUMN = ROOT / "configs" / "column_a0.5.yaml"
X_STEP = 0.1          # the block's face [m]


def _block_with_film(film: float) -> BoundaryPolygon:
    """A mass [0, 0.1] × [0, 0.05] (wall at x = 0) ending in a flat film [0.1, 0.15] × [0, t]."""
    pts = np.array([[0.0, 0.0], [X_STEP, 0.0], [0.15, 0.0], [0.15, film], [X_STEP, film],
                    [X_STEP, 0.05], [0.0, 0.05]])
    tags = np.array([BED, BED, SURFACE, SURFACE, SURFACE, SURFACE, WALL])
    return BoundaryPolygon(pts, tags)


def _slumped_tip() -> BoundaryPolygon:
    """A slumped column: the top falls at slope 1 from (0.1, 0.05) to (0.15, 0.0008) and a
    film 0.8 mm thick thins to the toe at x = 0.17 (steeper than μ_s: it would flow)."""
    xs = np.linspace(0.17, 0.1, 36)
    top = np.where(xs < 0.15, (0.15 - xs) + 0.0008, 0.0008 * (0.17 - xs) / 0.02)
    pts = np.vstack([[[0.0, 0.0], [X_STEP, 0.0]], np.column_stack([xs, top]), [[0.0, 0.05]]])
    tags = np.array([BED, BED] + [SURFACE] * 36 + [WALL])
    return BoundaryPolygon(pts, tags)


def _cfg(*overrides):
    return load_config(COLUMN, list(overrides))


def test_the_face_slope_is_the_lower_of_the_material_and_the_bed_friction():
    cfg = _cfg()
    assert cfg.numerics.remesh_film_trim_face == "repose"
    assert film_face_slope(cfg) == pytest.approx(0.32, rel=1e-4)               # no slip: mu_s
    slippery = _cfg("boundary.bed_condition=coulomb", "boundary.bed_friction_angle=10")
    assert film_face_slope(slippery) == pytest.approx(np.tan(np.radians(10.0)))
    rough = _cfg("boundary.bed_condition=coulomb", "boundary.bed_friction_angle=30.9638")
    assert film_face_slope(rough) == pytest.approx(0.32, rel=1e-4)
    assert film_face_slope(_cfg("numerics.remesh_film_trim_face=vertical")) is None
    with pytest.raises(ConfigError) as err:
        _cfg("numerics.remesh_film_trim_face=slanted")
    assert "numerics.remesh_film_trim_face" in str(err.value) and "\n" not in str(err.value)


def test_a_run_saved_before_the_key_keeps_the_vertical_cut():
    saved = config_to_dict(_cfg())
    del saved["numerics"]["remesh_film_trim_face"]
    assert validate_config(from_saved(saved)).numerics.remesh_film_trim_face == "vertical"


def test_the_cut_face_lies_at_the_angle_of_repose():
    cfg = _cfg()
    delta, mu = film_trim_thickness(cfg), film_face_slope(cfg)
    poly = _slumped_tip()
    cut = repair_polygon(poly, delta, mu)
    vertical = repair_polygon(poly, delta)
    assert polygon_is_simple(cut.points)
    x_d = vertical.points[:, 0].max()            # the vertical cut's x_δ
    assert 0.1 < x_d < 0.15
    # the face: from the foot on the bed at x_δ + δ/μ_r, at slope −μ_r
    foot = x_d + delta / mu
    assert cut.points[:, 0].max() == pytest.approx(foot, abs=1e-10)   # the rays: ± 1e-12 m
    i = int(np.argmax(cut.points[:, 0]))
    assert cut.points[i, 1] == 0.0 and cut.edge_tags[i] == SURFACE
    nxt = cut.points[(i + 1) % len(cut)]
    assert nxt[1] / (cut.points[i, 0] - nxt[0]) == pytest.approx(mu, rel=1e-6)
    # the mass ahead of x_δ lies under the line; the mass behind it is the vertical cut's
    ahead = cut.points[:, 0] > x_d
    assert np.all(cut.points[ahead, 1] <= delta - mu * (cut.points[ahead, 0] - x_d) + 1e-11)
    assert signed_area(vertical.points) < signed_area(cut.points) < signed_area(poly.points)


@pytest.mark.parametrize("film_in_grains", [0.3, 0.8])
def test_the_film_under_the_face_is_kept_to_round_off(film_in_grains):
    """A flat film t < δ ahead of a block: the kept film is the trapezoid under the line
    through (x_δ, δ), t (δ − t)/μ + t²/(2μ), exactly; the vertical cut keeps none of it."""
    cfg = _cfg()
    delta, mu = film_trim_thickness(cfg), film_face_slope(cfg)
    t = film_in_grains * delta
    block = 0.1 * 0.05
    cut = repair_polygon(_block_with_film(t), delta, mu)
    kept = t * (delta - t) / mu + t * t / (2.0 * mu)
    assert signed_area(cut.points) - block == pytest.approx(kept, rel=1e-9)
    assert signed_area(repair_polygon(_block_with_film(t), delta).points) == \
        pytest.approx(block, rel=1e-12)


def test_a_film_at_rest_under_the_face_is_not_cut_again():
    """A trimmed tip trimmed again loses nothing: the film kept under the face (at rest:
    not steeper than μ_r) stays at every later remesh. (Points of the earlier face lie on
    the wedge's ray up to round-off; counted inside, the second cut took the whole film:
    −2.0e-5 m², measured before the 1e-12 m tolerance of ``geometry.film_face``.)"""
    cfg = _cfg()
    delta, mu = film_trim_thickness(cfg), film_face_slope(cfg)
    once = repair_polygon(_slumped_tip(), delta, mu)
    twice = repair_polygon(once, delta, mu)
    assert signed_area(twice.points) == pytest.approx(signed_area(once.points), rel=1e-14)
    assert twice.points[:, 0].max() == pytest.approx(once.points[:, 0].max(), abs=1e-14)


def _area(mesh) -> float:
    import ufl
    from dolfinx import fem

    local = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh)))
    return mesh.comm.allreduce(local, op=MPI.SUM)


def test_the_face_is_at_repose_only_below_the_slump_speed():
    cfg = _cfg()
    assert film_face_speed(cfg) == pytest.approx(np.sqrt(9.81 * 1.6667e-3))   # 0.128 m/s


@pytest.mark.mpi
def test_a_remesh_cuts_at_repose_and_keeps_the_area():
    """The remesh of a slumped tip (``MovingDomain.remesh``, area put back): at rest the mesh
    ends at the face's foot x_δ + δ/μ_r, not at x_δ; with the front faster than √(g δ) (a
    flowing front) at x_δ (the vertical cut); the area kept to round-off either way."""
    cfg = _cfg()
    delta, mu, speed = film_trim_thickness(cfg), film_face_slope(cfg), film_face_speed(cfg)
    poly = _slumped_tip()
    comm = MPI.COMM_WORLD
    tagged = mesh_polygon(comm, poly.points, poly.edge_tags, 0.01)
    area0 = _area(tagged.mesh)
    x_d = repair_polygon(poly, delta).points[:, 0].max()
    for slope, front, end in ((mu, 0.0, x_d + delta / mu), (mu, 1.5 * speed, x_d),
                              (None, 0.0, x_d)):
        domain = MovingDomain(12.0, 0.01, trim_thickness=delta, conserve_area=True,
                              surgery=True, trim_face_slope=slope, trim_face_speed=speed)
        domain.front_speed = front
        new, _ = domain.remesh(tagged, area0)
        assert _area(new.mesh) == pytest.approx(area0, rel=1e-12)
        x_max = comm.allreduce(new.mesh.geometry.x[:, 0].max(), op=MPI.MAX)
        assert x_max == pytest.approx(end, abs=1e-4)   # the offset putting the area back: 5e-5 m
