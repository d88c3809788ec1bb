"""The exact overlap of triangles with convex polygons (the initial c and c_L of the
two-phase model): hand values, the rectangle as one case, the erodible scene's union of
layer and trapezoid summing to its analytic area, and the scene's config errors."""

import math

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.errors import ConfigError
from dpcollapse.models.two_phase.fraction import owned_triangles
from dpcollapse.models.two_phase.overlap import polygon_fraction, rectangle_fraction, union_fraction
from dpcollapse.scenes.registry import scene
from tests.helpers import ROOT

CONFIG = ROOT / "configs" / "erodible_eulerian.yaml"
UNIT = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])      # the triangle x, y ≥ 0, x + y ≤ 1


def _areas(tri):
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


@pytest.mark.parametrize("polygon, expected", [
    # the square [0, 0.5]² lies in the triangle: 0.25 of its 0.5
    ([(0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5)], 0.5),
    # the triangle lies in the unit square: all of it
    ([(0, 0), (1, 0), (1, 1), (0, 1)], 1.0),
    # the triangle below the diagonal y ≤ x of the square [0, 1]²: half of it
    ([(0, 0), (1, 0), (1, 1)], 0.5),
    # the triangle (0,0), (2,0), (0,2) holds it: 1; the square [0.5, 1]² misses it but at a corner
    ([(0, 0), (2, 0), (0, 2)], 1.0),
    ([(0.5, 0.5), (1, 0.5), (1, 1), (0.5, 1)], 0.0),
    # the half-plane x ≥ 0.5 (a big square): the corner triangle of area 0.125 of 0.5
    ([(0.5, -1), (3, -1), (3, 3), (0.5, 3)], 0.25),
    # a sloped trapezoid x ≤ 0.5 + (1 − y)/2 over y ≤ 1: cuts the triangle along x + y ≤ 1
    # and x ≤ 1 − y/2, which x + y ≤ 1 already implies: all of it
    ([(0, 0), (1, 0), (0.5, 1), (0, 1)], 1.0),
    # a thin layer y ≤ 0.1: 0.1 (1 − 0.05) of 0.5
    ([(-1, 0), (2, 0), (2, 0.1), (-1, 0.1)], 0.19),
])
def test_polygon_overlap_by_hand(polygon, expected):
    assert polygon_fraction(UNIT, polygon)[0] == pytest.approx(expected, abs=1e-15)


def test_a_large_cell_holds_a_polygon():
    """The triangle (0,0), (4,0), (0,4) (area 8) holds the sloped trapezoid
    (0,0), (1,0), (0.5,1), (0,1) of area 0.75: 0.75/8."""
    big = 4.0 * UNIT
    trapezoid = [(0, 0), (1, 0), (0.5, 1), (0, 1)]
    assert polygon_fraction(big, trapezoid)[0] == pytest.approx(0.75 / 8, abs=1e-15)


def test_the_rectangle_is_a_polygon():
    """rectangle_fraction and polygon_fraction of the same rectangle agree to round-off on a
    mesh that cuts it, and the rectangle keeps its exact area."""
    mesh = compat.create_rectangle(MPI.COMM_SELF, (0, 0), (0.3, 0.2), (13, 7))
    tri = owned_triangles(mesh)
    lower, upper = (0.011, 0.0), (0.1234, 0.0567)
    rect = rectangle_fraction(tri, lower, upper)
    poly = polygon_fraction(tri, [lower, (upper[0], lower[1]), upper, (lower[0], upper[1])])
    assert np.abs(rect - poly).max() < 1e-13
    assert np.dot(rect, _areas(tri)) == pytest.approx(0.1124 * 0.0567, rel=1e-13)


def test_layer_and_trapezoid_sum_to_their_area():
    """c = overlap with layer ∪ trapezoid on a box mesh whose lines miss y = h_e and the
    sloped ends: Σ c_K |K| = the config's analytic area (layer with its sloped end plus the
    trapezoid), c ≤ 1, cut cells along the layer top and the flank, the layer alone its
    analytic area."""
    cfg = load_config(CONFIG)
    g = cfg.geometry
    mesh = compat.create_rectangle(MPI.COMM_SELF, (0, 0), (1.0, 0.3), (37, 13))
    tri = owned_triangles(mesh)
    vessel = scene(cfg).container((1.0, 0.3))
    layer, mass = vessel.fraction_region
    assert vessel.bed_layer is layer and vessel.front_floor == pytest.approx(2 * g.layer_thickness)
    c = union_fraction(tri, [layer, mass])
    areas = _areas(tri)
    assert np.dot(c, areas) == pytest.approx(g.area, rel=1e-12)
    assert np.dot(polygon_fraction(tri, layer), areas) == pytest.approx(g.layer_area, rel=1e-12)
    trapezoid = 0.5 * (g.base_length + g.base_length - g.height / math.tan(math.radians(70))) * g.height
    assert np.dot(polygon_fraction(tri, mass), areas) == pytest.approx(trapezoid, rel=1e-12)
    assert c.min() >= 0 and c.max() <= 1
    assert ((c > 0) & (c < 1)).sum() > 40


@pytest.mark.parametrize("override, key", [
    ("model.box_length=0.7", "model.box_length"),      # the layer reaches 0.80 m
    ("model.box_height=0.25", "model.box_height"),     # the mass stands 0.255 m
])
def test_the_box_must_hold_layer_and_mass(override, key):
    with pytest.raises(ConfigError) as err:
        load_config(CONFIG, [override])
    assert key in str(err.value) and "\n" not in str(err.value)
