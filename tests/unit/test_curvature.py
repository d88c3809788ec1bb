"""Seed 000's discrete curvature and local surface tension against hand values (issue 14)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.forms.surface_tension import surface_tension
from dpcollapse.geometry.curvature import (
    bump_weights,
    discrete_curvature,
    local_surface_tension,
    turning_angles,
)


def _arc(radius, count, start=0.0, stop=math.pi, clockwise=False):
    theta = np.linspace(start, stop, count)
    if clockwise:
        theta = theta[::-1]
    return radius * np.column_stack([np.cos(theta), np.sin(theta)])


def test_curvature_of_a_circle_is_exact_for_the_inscribed_polygon():
    """Nodes on a circle of radius R, spacing angle φ: δθ = φ and |R_i| = 2R sin(φ/2), so
    C = φ / (2R sin(φ/2)) exactly, → 1/R as φ → 0; counter-clockwise (mass inside) is
    convex, positive; the same arc clockwise is concave, negative."""
    R, count = 0.2, 41
    phi = math.pi / (count - 1)
    c = discrete_curvature(_arc(R, count))
    assert c[0] == 0.0 and c[-1] == 0.0
    assert c[1:-1] == pytest.approx(phi / (2 * R * math.sin(phi / 2)), rel=1e-12)
    assert c[1:-1] == pytest.approx(1 / R, rel=1e-3)
    assert discrete_curvature(_arc(R, count, clockwise=True))[1:-1] == pytest.approx(
        -c[1:-1], rel=1e-12)


def test_curvature_of_a_polygon_by_hand():
    """A right-angle left turn between edges of 1 and 3: C = (π/2) / ((1 + 3)/2) = π/4; a
    straight node: 0; a 45° left turn between edges of 2 and √2: C = (π/4) / ((2 + √2)/2)."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 3.0], [1.0, 5.0], [0.0, 6.0]])
    c = discrete_curvature(pts)
    assert c[1] == pytest.approx((math.pi / 2) / 2.0)       # (|R_1| + |R_2|)/2 = (1 + 3)/2
    assert c[2] == pytest.approx(0.0, abs=1e-15)            # straight on
    assert c[3] == pytest.approx((math.pi / 4) / ((2 + math.sqrt(2)) / 2))  # left 45°
    assert turning_angles(pts) == pytest.approx([math.pi / 2, 0.0, math.pi / 4])


def test_a_fold_turns_through_almost_pi():
    """A surface that folds back on itself turns by nearly ±π at the fold node."""
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1e-3]])
    assert abs(turning_angles(pts)[0]) == pytest.approx(math.pi - 1e-3, abs=1e-6)


def test_bump_weights():
    w = bump_weights(9, 4, 2.0)
    assert w[4] == 1.0
    assert w[3] == pytest.approx((1 - 0.25) ** 2) and w[5] == w[3]
    assert np.all(w[[0, 1, 2, 6, 7, 8]] == 0.0)
    with pytest.raises(ValueError):
        bump_weights(5, 2, 0.0)


def test_local_surface_tension_is_centred_on_the_largest_curvature():
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.1, 0.5], [2.2, 0.5],
                    [3.0, 0.5], [4.0, 0.5]])
    c = discrete_curvature(pts)
    centre = int(np.argmax(np.abs(c)))
    gamma = local_surface_tension(pts, 0.01, 1.5)
    assert np.argmax(np.abs(gamma)) == centre
    assert gamma[centre] == pytest.approx(0.01 * c[centre])
    assert np.all(gamma[np.abs(np.arange(len(pts)) - centre) >= 1.5] == 0.0)
    assert not np.any(local_surface_tension(pts, 0.0, 1.5))
    assert not np.any(local_surface_tension(np.array([[0.0, 0], [1, 0], [2, 0]]), 1.0, 2.0))


def test_surface_tension_term_assembled_alone():
    """−∫_top γ v·N ds on the unit square's top (N = (0, 1)), γ = 3 Pa, v = (x, y + 1):
    −∫_0^1 3·(1 + 1) dx = −6."""
    msh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (2, 2))
    fdim = msh.topology.dim - 1
    from dolfinx import mesh as dmesh

    top = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[1], 1.0))
    tags = compat.meshtags(msh, fdim, top, np.full(len(top), 3, dtype=np.int32))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    x = ufl.SpatialCoordinate(msh)
    v = ufl.as_vector([x[0], x[1] + 1.0])
    gamma = fem.Constant(msh, compat.ScalarType(3.0))
    value = fem.assemble_scalar(fem.form(surface_tension(gamma, v, ufl.FacetNormal(msh), ds(3))))
    assert value == pytest.approx(-6.0, rel=1e-12)
