"""The trapezoid mesh: physical tags and exact area."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse.config import load_config
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.trapezoid import build_mesh, trapezoid_polygon, write_msh
from tests.helpers import ROOT


def _area(mesh):
    return mesh.comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)


def _tag_length(tagged, tag):
    ds = ufl.Measure("ds", domain=tagged.mesh, subdomain_data=tagged.facet_tags)
    one = fem.Constant(tagged.mesh, 1.0)
    return tagged.mesh.comm.allreduce(fem.assemble_scalar(fem.form(one * ds(tag))), op=MPI.SUM)


@pytest.mark.mpi
def test_trapezoid_tags_and_area(comm):
    cfg = load_config(ROOT / "configs/rigid.yaml", ["geometry.mesh_size=0.02"])
    tagged = build_mesh(cfg, comm)
    g = cfg.geometry
    top = g.base_length - g.height / math.tan(math.radians(g.flank_angle))
    assert _area(tagged.mesh) == pytest.approx((g.base_length + top) / 2 * g.height, abs=1e-10)
    assert _tag_length(tagged, BED) == pytest.approx(g.base_length, abs=1e-12)
    assert _tag_length(tagged, WALL) == pytest.approx(g.height, abs=1e-12)
    flank = g.height / math.sin(math.radians(g.flank_angle))
    assert _tag_length(tagged, SURFACE) == pytest.approx(top + flank, abs=1e-12)


def test_polygon_vertices():
    pts, tags = trapezoid_polygon(0.25, 0.297, 70.0)
    np.testing.assert_allclose(pts[2], [0.297 - 0.25 / math.tan(math.radians(70)), 0.25])
    assert list(tags) == [BED, SURFACE, SURFACE, WALL]


def test_write_msh_and_read_back(tmp_path):
    cfg = load_config(ROOT / "configs/rigid.yaml", ["geometry.mesh_size=0.03"])
    path = write_msh(cfg, tmp_path / "rigid.msh")
    cfg2 = load_config(ROOT / "configs/rigid.yaml", [f"geometry.mesh_file={path}"])
    tagged = build_mesh(cfg2, MPI.COMM_SELF)
    assert _area(tagged.mesh) == pytest.approx(cfg.geometry.area, abs=1e-10)
    assert set(np.unique(tagged.facet_tags.values)) == {BED, WALL, SURFACE}
