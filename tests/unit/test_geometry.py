"""The trapezoid mesh: physical tags and exact area."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse.config import load_config
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.scenes.registry import build_mesh, write_msh
from dpcollapse.scenes.trapezoid import trapezoid_polygon
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


def test_boundary_segments_one_edge_per_polygon_edge_unless_graded():
    """gmsh would split every polygon edge slightly longer than h in two; the remesh
    polygon's edges (≤ 1.5 h) stay single mesh edges, except one more than twice as long
    as a neighbour; edges longer than 1.5 h are left to gmsh (0)."""
    from dpcollapse.geometry.mesher import boundary_segments

    h = 0.01
    # a square-ish loop: bottom edges 1.2 h, 0.3 h, 1.4 h; a long right side; a long top
    pts = np.array([[0, 0], [0.012, 0], [0.015, 0], [0.029, 0], [0.029, 0.05], [0, 0.05]])
    tags = np.array([BED, BED, BED, WALL, SURFACE, WALL])
    segments = boundary_segments(pts, tags, lambda p, t: h)
    # 1.2 h next to a 0.3 h edge: ⌈1.2/0.6⌉ = 2; the 0.3 h edge: 1; 1.4 h next to 0.3 h: ⌈1.4/0.6⌉ = 3
    assert segments == [2, 1, 3, 0, 0, 0]
    even = np.array([[0, 0], [0.012, 0], [0.024, 0], [0.024, 0.012], [0.012, 0.012], [0, 0.012]])
    assert boundary_segments(even, tags, lambda p, t: h) == [1] * 6


def test_remesh_keeps_the_cell_count(comm):
    """Remeshing at h = 2 cm a boundary whose edges are 1.2 h long gives about as many cells
    as meshing the shape at h directly (it used to give 2–3 times as many: gmsh split every
    edge longer than h in two and extended the halved spacing inwards)."""
    from dpcollapse import compat
    from dpcollapse.ale.remesh import remesh_domain

    def count(m):
        return comm.allreduce(compat.num_owned_cells(m), op=MPI.SUM)

    coarse = build_mesh(load_config(ROOT / "configs/rigid.yaml", ["geometry.mesh_size=0.024"]), comm)
    direct = build_mesh(load_config(ROOT / "configs/rigid.yaml", ["geometry.mesh_size=0.02"]), comm)
    new, _, _ = remesh_domain(coarse, 0.02, None, 1e-9)
    assert count(new.mesh) == pytest.approx(count(direct.mesh), rel=0.15)
    assert _area(new.mesh) == pytest.approx(_area(coarse.mesh), rel=1e-9)


def test_gmsh_never_asks_and_never_reads_stdin():
    """Inside a gmsh session gmsh answers its own questions (General.NoPopup: its "very
    large mesh. Do you really want to continue?" read the answer from stdin, issue 47) and
    file descriptor 0 is /dev/null; after it, stdin is the caller's again."""
    import os

    from dpcollapse.geometry.mesher import gmsh_session

    before = os.fstat(0)
    with gmsh_session() as gmsh:
        assert gmsh.option.getNumber("General.NoPopup") == 1
        assert os.path.samestat(os.fstat(0), os.stat(os.devnull))
        assert os.read(0, 1) == b""
    assert os.path.samestat(os.fstat(0), before)
