"""The column scene — one module (scenes/column.py) and one config class (ColumnGeometry),
with the time loop untouched — and the geometry classes told apart by ``shape``."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import config as config_module
from dpcollapse.config import ColumnGeometry, LayerGeometry, TrapezoidGeometry, load_config
from dpcollapse.errors import ConfigError
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.scenes.column import ColumnScene
from dpcollapse.scenes.registry import scene
from tests.helpers import ROOT, simulation

COLUMN = ROOT / "configs/column.yaml"


def test_each_shape_has_its_config_class():
    assert isinstance(load_config(ROOT / "configs/rigid.yaml").geometry, TrapezoidGeometry)
    assert isinstance(load_config(ROOT / "configs/plug.yaml").geometry, LayerGeometry)
    g = load_config(COLUMN).geometry
    assert isinstance(g, ColumnGeometry) and (g.height, g.base_length) == (0.14, 0.07)
    assert g.area == pytest.approx(0.14 * 0.07) and g.aspect_ratio == pytest.approx(2.0)
    assert isinstance(load_config(None).geometry, TrapezoidGeometry)   # no shape: trapezoid


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["geometry.shape=cone"], "geometry.shape = 'cone': must be one of 'trapezoid', 'layer', 'column'"),
        (["geometry.shape=column", "geometry.flank_angle=80"], "geometry.flank_angle: unknown key;"),
        (["geometry.shape=column", "geometry.height=-1"], "geometry.height = -1: must be > 0 (m)"),
        (
            ["geometry.shape=column", "geometry.mesh_size=0.2"],
            "geometry.mesh_size = 0.2: larger than the column",
        ),
        (
            ["geometry.shape=layer", "geometry.bed_angel=3"],
            "geometry.bed_angel: unknown key; did you mean 'bed_angle'?",
        ),
    ],
)
def test_geometry_errors_name_the_key_without_the_class(overrides, message):
    with pytest.raises(ConfigError) as info:
        load_config(None, overrides)
    assert str(info.value).startswith(message), str(info.value)


def test_a_renamed_key_is_refused_with_the_new_name(monkeypatch):
    monkeypatch.setitem(config_module.RENAMED, ("numerics", "picard_rtol"), "numerics.nonlinear_rtol")
    with pytest.raises(ConfigError, match=r"numerics.picard_rtol: renamed; use numerics.nonlinear_rtol"):
        load_config(None, ["numerics.picard_rtol=1e-3"])


def test_column_scene_boundaries_and_mesh():
    """Bed (Coulomb μ_b), frictionless symmetry wall x = 0 (u·n = 0 on u_x), free surface;
    the mesh is the rectangle [0, L0] × [0, H0] with cell tags."""
    cfg = load_config(COLUMN, ["geometry.mesh_size=0.02"])
    sc = scene(cfg)
    assert isinstance(sc, ColumnScene)
    bed, wall, surface = sc.boundaries()
    assert (bed.tag, bed.kind) == (BED, BoundaryKind.COULOMB)
    assert bed.friction == pytest.approx(math.tan(math.radians(25.5)))
    assert (wall.tag, wall.kind, wall.axis, wall.has_friction) == (WALL, BoundaryKind.SLIP, 0, False)
    assert (surface.tag, surface.kind) == (SURFACE, BoundaryKind.FREE_SURFACE)
    tagged = sc.mesh(MPI.COMM_SELF)
    x = tagged.mesh.geometry.x
    assert (x[:, 0].min(), x[:, 0].max(), x[:, 1].min(), x[:, 1].max()) == (0.0, 0.07, 0.0, 0.14)
    area = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=tagged.mesh)))
    assert area == pytest.approx(0.14 * 0.07, rel=1e-12)
    assert tagged.cell_tags is not None


def test_column_collapses_and_slides_along_the_symmetry_wall(tmp_path):
    """configs/column.yaml shortened (2 cm, 30 steps): the column spreads beyond L0 with its
    area kept; on the symmetry wall u_x = 0 exactly while the mass slides down it (no
    friction: u_y < 0 there)."""
    sim = simulation(COLUMN, ["geometry.mesh_size=0.02", "time.end_time=0.03",
                              "time.output_every=1000", "time.checkpoint_every=1000"],
                     tmp_path, comm=MPI.COMM_SELF)
    summary = sim.run()
    assert summary["status"] == "end_time" and summary["steps"] >= 30
    assert summary["front"] > 0.07 + 1e-3
    assert abs(summary["area_drift"]) < 1e-3
    flow = sim.disc.flow
    xy = flow.V.tabulate_dof_coordinates()[:, :2]
    u = flow.u_old.x.array.reshape(-1, 2)
    on_wall = (xy[:, 0] == 0.0) & (xy[:, 1] > 0.01)
    assert on_wall.sum() >= 5
    assert np.abs(u[on_wall, 0]).max() == 0.0
    assert u[on_wall, 1].min() < -0.01


@pytest.mark.mpi
def test_column_on_all_ranks_matches_serial(shared_tmp, comm):
    """The shortened column collapse on all ranks gives the serial diagnostics (rel. 1e-6)."""
    from dpcollapse.io.diagnostics import read_diagnostics

    over = ["geometry.mesh_size=0.02", "time.end_time=0.02", "time.output_every=1000",
            "time.checkpoint_every=1000"]
    simulation(COLUMN, over, shared_tmp / "parallel", comm=comm).run()
    if comm.rank == 0:
        simulation(COLUMN, over, shared_tmp / "serial", comm=MPI.COMM_SELF).run()
        par = read_diagnostics(shared_tmp / "parallel" / "diagnostics.csv")
        ser = read_diagnostics(shared_tmp / "serial" / "diagnostics.csv")
        assert par["iterations"] == ser["iterations"]
        for key in ("t", "front", "max_height", "kinetic_energy", "area", "max_speed"):
            np.testing.assert_allclose(par[key], ser[key], rtol=1e-6, atol=1e-12, err_msg=key)
