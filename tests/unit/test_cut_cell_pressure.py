"""model.cut_cell_pressure (issue 27, docs/benchmarks/2026-12-04-cut-cell-pressure.md): with
``centroid`` the grains' friction in a cell the interface cuts (0 < c < 1) sees the P1
pressure's value at the cell's centroid; full and empty cells, and ``pointwise`` (the default),
keep p(x). Checked on a tiny mesh against hand values (the centroid value of a linear p is its
cell average), the centroid field under MPI-local ghosts, the model built from a config, and
the key's default and refusal."""

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.forms.two_phase import CUT_CELL_PRESSURES, cut_cell_pressure
from dpcollapse.models.two_phase.flow import cell_centroids
from tests.helpers import ROOT, refusal_message, simulation

CONFIG = ROOT / "configs" / "column_eulerian_a1.42.yaml"
LENGTH, HEIGHT = 0.3, 0.2


@pytest.fixture(scope="module")
def mesh():
    return compat.create_rectangle(MPI.COMM_SELF, (0, 0), (LENGTH, HEIGHT), (3, 2))


def _cellwise(expression, mesh):
    """∫_K expression dx of every cell K (a DG0 test function)."""
    v = ufl.TestFunction(compat.scalar_space(mesh, 0, "DG"))
    vector = fem.assemble_vector(fem.form(expression * v * ufl.dx(domain=mesh)))
    return vector.array.copy()


def _fraction(mesh, values):
    c = fem.Function(compat.scalar_space(mesh, 0, "DG"))
    c.x.array[:] = values
    return c


def test_centroids_are_the_cells_means(mesh):
    """∫_K (x − x_K) dx = 0 in every cell: the field holds each cell's own centroid."""
    centroid = cell_centroids(mesh)
    x = ufl.SpatialCoordinate(mesh)
    for i in range(2):
        assert np.abs(_cellwise(x[i] - centroid[i], mesh)).max() < 1e-15
    areas = _cellwise(1.0, mesh)
    assert areas.sum() == pytest.approx(LENGTH * HEIGHT, rel=1e-12)


@pytest.mark.mpi
def test_centroids_on_every_rank():
    """The same on a mesh partitioned over the ranks (serial or mpirun -n 2): every owned
    cell holds its own centroid, and the x_K of ghost cells are their owner's."""
    mesh = compat.create_rectangle(MPI.COMM_WORLD, (0, 0), (LENGTH, HEIGHT), (12, 8))
    centroid = cell_centroids(mesh)
    x = ufl.SpatialCoordinate(mesh)
    owned = compat.num_owned_cells(mesh)
    for i in range(2):
        local = np.abs(_cellwise(x[i] - centroid[i], mesh)[:owned]).max()
        assert mesh.comm.allreduce(local, op=MPI.MAX) < 1e-15
    before = centroid.x.array.copy()
    centroid.x.scatter_forward()
    assert np.array_equal(before, centroid.x.array)
    area = mesh.comm.allreduce(_cellwise(1.0, mesh)[:owned].sum(), op=MPI.SUM)
    assert area == pytest.approx(LENGTH * HEIGHT, rel=1e-12)


def test_centroid_pressure_by_hand(mesh):
    """p = 1000 (H − y) + 50 x Pa (linear, exact in P1). In cut cells ``centroid`` is constant,
    p(x_K) = the cell average; in full and empty cells it is p(x); ``pointwise`` is p(x)."""
    p = fem.Function(compat.scalar_space(mesh, 1))
    p.interpolate(lambda x: 1000.0 * (HEIGHT - x[1]) + 50.0 * x[0])
    ncells = compat.num_owned_cells(mesh)
    values = np.tile([0.0, 0.3, 1.0], ncells)[:ncells]   # empty, cut, full in turn
    c = _fraction(mesh, values)
    centroid = cell_centroids(mesh)
    areas = _cellwise(1.0, mesh)
    averages = _cellwise(p, mesh) / areas
    seen = cut_cell_pressure(p, c, centroid, mesh, "centroid")
    # the value's deviation from p(x), cell by cell: zero where not cut
    deviation = _cellwise((seen - p) ** 2, mesh)
    cut = (values > 0) & (values < 1)
    assert np.abs(deviation[~cut]).max() < 1e-20
    assert deviation[cut].min() > 1.0      # p varies by ~20 Pa across a 0.1 m cell
    # where cut: the cell average, constant in the cell
    assert _cellwise(seen, mesh)[cut] / areas[cut] == pytest.approx(averages[cut], rel=1e-12)
    constant = fem.Function(compat.scalar_space(mesh, 0, "DG"))
    constant.x.array[:] = averages
    assert np.abs(_cellwise((seen - constant) ** 2, mesh)[cut]).max() < 1e-16
    assert cut_cell_pressure(p, c, None, mesh, "pointwise") is p
    with pytest.raises(ValueError, match="pointwise, centroid"):
        cut_cell_pressure(p, c, centroid, mesh, "surface")


def test_the_model_reads_the_key(tmp_path):
    """The two-phase model of the a = 1.42 column (2 cm) with ``centroid``: in a cut cell
    the grains' yield stress is κ at the centroid's pressure (the total pressure: p itself
    elsewhere)."""
    over = ["geometry.mesh_size=0.02", "model.cut_cell_pressure=centroid", "model.grain_pressure=total"]
    flow = simulation(CONFIG, over, tmp_path, comm=MPI.COMM_SELF).disc.flow
    pressure = fem.Function(flow.Q)
    pressure.interpolate(lambda x: 1000.0 * (0.5 - x[1]))
    flow.iterate.x.array[flow.pressure_dofs] = pressure.x.array
    c = flow.fraction.c.x.array
    cut = (c > 0) & (c < 1)
    assert cut.any()
    seen = _cellwise((flow.grain_pressure - pressure) ** 2, flow.mesh)
    assert seen[~cut[: len(seen)]].max() < 1e-12
    assert seen[cut[: len(seen)]].max() > 1e-6


def test_the_key_defaults_to_centroid(capsys):
    assert load_config(CONFIG).model.cut_cell_pressure == "centroid"
    cfg = load_config(CONFIG, ["model.cut_cell_pressure=pointwise"])
    assert cfg.model.cut_cell_pressure == "pointwise"
    message = refusal_message(CONFIG, "model.cut_cell_pressure=surface",
                              "model.cut_cell_pressure", capsys)
    assert all(name in message for name in CUT_CELL_PRESSURES)
