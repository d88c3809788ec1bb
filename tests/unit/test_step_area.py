"""The area a mesh move loses (``ale.area``, ``numerics.step_conserve_area``, issue 49).

A move x ← x + Δt w with a P1 w changes the area by Δt ∫ div w + Δt² ∫ det ∇w exactly.
For the extensional w = ε (x, −y) (div w = 0, det ∇w = −ε²; w·n = 0 on the bed y = 0 and
the wall x = 0) the plain move loses exactly Δt² ε² A; with the area kept it loses nothing,
and the bed and wall nodes stay on their sides."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.ale.motion import MeshMotion
from dpcollapse.config import load_config
from dpcollapse.models.stokes.discretization import make_flow
from dpcollapse.scenes.registry import build_mesh
from tests.helpers import ROOT

RIGID = ROOT / "configs" / "rigid.yaml"
EPS, DT = 5.0, 0.01     # [1/s], [s]: Δt² ε² = 2.5e-3 of the area lost by the plain move


def _moved(conserve: bool):
    """(area before, area after, bed y after, wall x after) of one extensional move."""
    comm = MPI.COMM_WORLD
    cfg = load_config(RIGID, ["geometry.mesh_size=0.04", "time.scheme=bdf1",
                              "time.tolerance=null"])
    flow = make_flow(build_mesh(cfg, comm), cfg)
    motion = MeshMotion(flow, cfg.numerics.mesh_velocity_penalty, conserve_area=conserve)
    motion.w.interpolate(lambda x: np.vstack([EPS * x[0], -EPS * x[1]]))
    x = flow.mesh.geometry.x
    w = motion.w.x.array.reshape(-1, 2)
    w[motion._node_dof[x[:, 1] == 0.0], 1] = 0.0   # w·n = 0 exactly on the bed and the
    w[motion._node_dof[x[:, 0] == 0.0], 0] = 0.0   # wall, as the motion's conditions make it
    bed = motion._bed_nodes
    wall = np.flatnonzero(np.isclose(x[:, 0], 0.0))
    keeper = motion.area_keeper or _plain_area(flow.mesh)
    before = keeper.area()
    motion.move(DT)
    after = keeper.area()
    out = (before, after, x[bed, 1].copy(), x[wall, 0].copy())
    motion.destroy()
    flow.destroy()
    return out


def _plain_area(mesh):
    from dpcollapse import compat
    from dpcollapse.ale.area import AreaKeeper
    from dpcollapse.ale.quality import signed_areas

    class Area(AreaKeeper):
        def __init__(self, mesh):   # only the area of the cells
            self.mesh = mesh
            gdm = compat.geometry_dofmap(mesh)
            self._owned = gdm[:compat.num_owned_cells(mesh)]
            self._sign = np.sign(signed_areas(mesh.geometry.x[:, :2][self._owned]))

    return Area(mesh)


@pytest.mark.mpi
def test_the_plain_move_loses_dt2_eps2_of_the_area():
    before, after, _, _ = _moved(conserve=False)
    assert after - before == pytest.approx(-(DT * EPS) ** 2 * before, rel=1e-9)


@pytest.mark.mpi
def test_the_kept_move_loses_nothing_and_keeps_bed_and_wall():
    before, after, bed_y, wall_x = _moved(conserve=True)
    assert abs(after - before) <= 1e-13 * before
    assert np.all(bed_y == 0.0)
    assert np.all(wall_x == 0.0)
