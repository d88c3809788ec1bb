"""The volume a mesh move loses in (r, z) (``ale.area`` axisymmetric,
``numerics.step_conserve_area`` with ``geometry.symmetry: axisymmetric``, issue 52).

The extensional mesh velocity w = ε (r, −2z) is free of axisymmetric divergence
(∂_r w_r + w_r/r + ∂_z w_z = ε + ε − 2ε = 0; w_r = 0 on the axis, w_z = 0 on the bed) and
linear, so the plain move x ← x + Δt w maps the body of revolution by r ← (1 + εΔt) r,
z ← (1 − 2εΔt) z: its volume 2π∫ r dA becomes exactly (1 + εΔt)²(1 − 2εΔt) of itself (lost:
3ε²Δt² + 2ε³Δt³ of it). With the volume kept it loses nothing, and the axis and bed nodes
stay on their sides. The area of the (r, z) section is then not kept (the keeper keeps the
body, not the section)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.ale.motion import MeshMotion
from dpcollapse.config import load_config
from dpcollapse.models.stokes.discretization import make_flow
from dpcollapse.scenes.registry import build_mesh
from tests.helpers import ROOT

CYLINDER = ROOT / "configs" / "column_axi_a0.5.yaml"
EPS, DT = 5.0, 0.01     # [1/s], [s]: 3ε²Δt² + 2ε³Δt³ = 7.75e-3 of the volume lost plainly


def _moved(conserve: bool):
    """(volume before, after, area before, after, bed z after, axis r after) of one move."""
    comm = MPI.COMM_WORLD
    cfg = load_config(CYLINDER, ["geometry.mesh_size=0.02", "time.scheme=bdf1",
                                 "time.tolerance=null"])
    flow = make_flow(build_mesh(cfg, comm), cfg)
    motion = MeshMotion(flow, cfg.numerics.mesh_velocity_penalty, conserve_area=conserve)
    motion.w.interpolate(lambda x: np.vstack([EPS * x[0], -2 * EPS * x[1]]))
    x = flow.mesh.geometry.x
    w = motion.w.x.array.reshape(-1, 2)
    w[motion._node_dof[x[:, 1] == 0.0], 1] = 0.0   # w·n = 0 exactly on the bed and the axis
    w[motion._node_dof[x[:, 0] == 0.0], 0] = 0.0   # (the interpolation leaves 1e-17 m/s)
    bed = motion._bed_nodes
    axis = np.flatnonzero(x[:, 0] == 0.0)
    volume, area = _measures(flow.mesh)
    before = volume(), area()
    motion.move(DT)
    after = volume(), area()
    out = (*before, *after, x[bed, 1].copy(), x[axis, 0].copy())
    motion.destroy()
    flow.destroy()
    return out


def _measures(mesh):
    """The volume 2π∫ r dA and the area of the mesh's cells, measured apart from the
    motion's keeper."""
    from dpcollapse import compat
    from dpcollapse.ale.area import AreaKeeper
    from dpcollapse.ale.quality import signed_areas

    class Cells(AreaKeeper):
        def __init__(self, mesh, axisymmetric):   # only the measure of the cells
            self.mesh, self.axisymmetric = mesh, axisymmetric
            gdm = compat.geometry_dofmap(mesh)
            self._owned = gdm[:compat.num_owned_cells(mesh)]
            self._sign = np.sign(signed_areas(mesh.geometry.x[:, :2][self._owned]))

    return Cells(mesh, True).area, Cells(mesh, False).area


@pytest.mark.mpi
def test_the_plain_move_loses_the_extensional_volume():
    v0, a0, v1, a1, _, _ = _moved(conserve=False)
    assert v0 == pytest.approx(np.pi * 0.1 ** 2 * 0.05, rel=1e-12)    # π r0² H0
    factor = (1 + EPS * DT) ** 2 * (1 - 2 * EPS * DT)
    assert v1 - v0 == pytest.approx((factor - 1) * v0, rel=1e-9)
    assert a1 - a0 == pytest.approx(((1 + EPS * DT) * (1 - 2 * EPS * DT) - 1) * a0, rel=1e-9)


@pytest.mark.mpi
def test_the_kept_move_keeps_the_volume_and_the_axis_and_bed():
    v0, a0, v1, a1, bed_z, axis_r = _moved(conserve=True)
    assert abs(v1 - v0) <= 1e-12 * v0
    # the section's area is not what is kept: it changes by O(Δt²) of itself
    assert abs(a1 - a0) > 1e-4 * a0
    assert np.all(bed_z == 0.0)
    assert np.all(axis_r == 0.0)
    assert MPI.COMM_WORLD.allreduce(len(axis_r), op=MPI.SUM) > 0    # some rank has the axis


def test_the_key_is_accepted_in_r_z():
    cfg = load_config(CYLINDER, ["numerics.step_conserve_area=true"])
    assert cfg.numerics.step_conserve_area and cfg.geometry.coordinates == "axisymmetric"


def test_the_column_configs_keep_the_volume_at_every_move():
    for path in sorted((ROOT / "configs").glob("column_axi_a*.yaml")):
        n = load_config(path).numerics
        assert n.step_conserve_area and n.remesh_conserve_area, path.name
