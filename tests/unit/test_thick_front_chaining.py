"""The thickness front of the moving mesh (``StokesDiscretization.thick_front``, a measure of
every step) chains the boundary edges once per mesh and reuses the chaining while the mesh
only moves (``geometry.boundary_loops``): the same front as a fresh ``chain_loops`` of the
moved boundary, at one chaining instead of one per step (issue 51: it was 15 % of a 2 cm run)."""

from mpi4py import MPI

from dpcollapse.config import load_config
from dpcollapse.geometry import boundary_loops, polygon
from dpcollapse.geometry.mesher import boundary_edges
from dpcollapse.models.stokes.discretization import StokesDiscretization
from dpcollapse.scenes.base import thickness_front
from dpcollapse.scenes.registry import build_mesh
from tests.helpers import ROOT


def test_thick_front_chains_once_per_mesh(monkeypatch):
    cfg = load_config(ROOT / "configs" / "rigid.yaml", ["geometry.mesh_size=0.04"])
    disc = StokesDiscretization(build_mesh(cfg, MPI.COMM_SELF), cfg)
    plain = polygon.chain_loops
    calls = []

    def counted(edges, tags):
        calls.append(len(tags))
        return plain(edges, tags)

    monkeypatch.setattr(polygon, "chain_loops", counted)
    monkeypatch.setattr(boundary_loops, "chain_loops", counted)
    x = disc.mesh.geometry.x
    fronts = []
    for k in range(4):
        # the mesh moves (a spreading: x stretched away from the wall), its topology stays
        x[:, 0] *= 1.0 + 0.05 * k
        front = disc.thick_front()
        edges, tags = boundary_edges(disc.tagged)
        expected = thickness_front(plain(edges, tags)[0].points, disc.film_threshold)
        assert front == expected
        fronts.append(front)
    assert len(calls) == 1            # chained on the first step only
    assert fronts[-1] > fronts[0]     # and the front did follow the moving mesh
    disc.destroy()
