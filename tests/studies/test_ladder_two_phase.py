"""The two-phase rung of the model ladder: its config, its end time, the front's stopping
time, and the trapezoid's vessel on the two-phase model."""

import math

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.models.two_phase.fraction import owned_triangles
from dpcollapse.models.two_phase.overlap import union_fraction
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.scenes.registry import scene
from studies import ladder
from tests.helpers import ROOT


def test_front_stop_time():
    t = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    assert ladder.front_stop_time(t, np.array([0.1, 0.2, 0.2995, 0.3, 0.3])) == 0.3
    assert ladder.front_stop_time(t, np.full(5, 0.3)) == 0.1            # never moved
    assert ladder.front_stop_time(t, np.array([0.1, 0.2, 0.3, 0.4, 0.5])) == 0.5  # still moving
    assert math.isnan(ladder.front_stop_time(np.zeros(0), np.zeros(0)))


def test_two_phase_end_follows_the_2d_rung():
    assert ladder.two_phase_end({"status_2d": "end_time", "t_end_2d": 0.5}) == 0.5
    assert ladder.two_phase_end({"status_2d": "at_rest", "t_end_2d": 0.2}) == ladder.TWO_PHASE_MIN_END
    assert ladder.two_phase_end({"status_2d": "at_rest", "t_end_2d": 0.9}) == pytest.approx(1.8)
    assert ladder.two_phase_end({"status_2d": "at_rest", "t_end_2d": 2.5}) == ladder.TWO_PHASE_MAX_END


@pytest.mark.parametrize("name, cell", [("column_a2", 0.07 / 16), ("rigid", 0.01),
                                        ("dam_break_slope22", 0.02)])
def test_two_phase_config_of_a_ladder_case(name, cell):
    """The case's scene, material and bed on the two-phase model, in the depth-averaged
    rung's domain: fine cells min(2D mesh, L0/16), the box above the mass."""
    case = next(c for c in ladder.full_plan() if c.name == name)
    cfg = case.load()
    _, grid, _, _ = ladder.sh_problem(cfg, ladder.SH_DX, case.sh_x_max)
    tp = ladder.two_phase_config(cfg, grid, 1.0)
    assert tp.model.name == "two_phase" and tp.model.min_cell == pytest.approx(cell)
    assert tp.model.box_length == grid.x_max and tp.model.box_height > cfg.geometry.height
    assert tp.material == cfg.material and tp.boundary == cfg.boundary
    assert tp.geometry == cfg.geometry and tp.time.end_time == 1.0


def test_trapezoid_vessel_holds_the_trapezoid():
    """configs/rigid.yaml on the two-phase model: c from the trapezoid's polygon sums to its
    area; the bed Coulomb μ_b, the wall Coulomb μ_l, the open top."""
    cfg = load_config(ROOT / "configs/rigid.yaml")
    g, b = cfg.geometry, cfg.boundary
    vessel = scene(cfg).container((1.0, 0.3))
    mesh = compat.create_rectangle(MPI.COMM_SELF, (0, 0), (1.0, 0.3), (41, 17))
    tri = owned_triangles(mesh)
    c = union_fraction(tri, list(vessel.fraction_region))
    a = tri[:, 1] - tri[:, 0]
    e = tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(a[:, 0] * e[:, 1] - a[:, 1] * e[:, 0])
    top = g.base_length - g.height / math.tan(math.radians(g.flank_angle))
    assert np.dot(c, area) == pytest.approx(0.5 * (g.base_length + top) * g.height, rel=1e-12)
    kinds = {bd.name: bd for bd in vessel.boundaries}
    assert kinds["bed"].kind == BoundaryKind.COULOMB and kinds["bed"].friction == pytest.approx(b.mu_bed)
    assert kinds["wall"].kind == BoundaryKind.COULOMB and kinds["wall"].friction == pytest.approx(b.mu_wall)
    assert kinds["top"].kind == BoundaryKind.FREE_SURFACE and vessel.bed_layer is None
