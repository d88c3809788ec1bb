"""A scene whose solid sides are slanted gives the answer of the same scene along the axes.

The rigid-bed trapezoid (Coulomb bed and wall) is rotated by φ with its gravity (bed angle
θ + φ): no side is then parallel to an axis, so u·n = 0 goes through Nitsche's terms
(``forms.no_penetration``) and the mesh velocity through its projection, where the
unrotated scene imposes both strongly on one component. The physics is the same, so the
first step's velocity, rotated back, must agree to the discretization difference between
the strong and the weak condition, for both models; the mesh velocity must slide along the
slanted sides exactly.

Measured (φ = 35°, 3 cm mesh, default tolerances): largest nodal difference 0.78 %
(regularized) and 1.0 % (augmented Lagrangian) of the largest speed, at the toe, where the
flank meets the bed (a stress singularity); RMS 0.44 %. With the fixed point converged to
1e-9 it stays 0.6 % / 0.10 %: it is the strong-against-weak difference, not the solver's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.ale.motion import MeshMotion
from dpcollapse.config import load_config
from dpcollapse.models.registry import model_class
from dpcollapse.models.stokes.discretization import flow_parameters
from dpcollapse.scenes.base import SOLID
from dpcollapse.scenes.registry import scene as make_scene
from tests.helpers import RIGID_BDF1, ROOT

PHI = math.radians(35.0)
R = np.array([[math.cos(PHI), -math.sin(PHI)], [math.sin(PHI), math.cos(PHI)]])


def first_step(method: str, rotate: bool):
    """(velocity dofs (n, 2) in the unrotated frame, the model, its parameters)."""
    cfg = load_config(ROOT / "configs/rigid.yaml", ["geometry.mesh_size=0.03", *RIGID_BDF1,
                                                   f"numerics.method={method}"])
    scene = make_scene(cfg)
    tagged = scene.mesh(MPI.COMM_WORLD)
    params = flow_parameters(cfg, scene)
    if rotate:
        tagged.mesh.geometry.x[:, :2] = tagged.mesh.geometry.x[:, :2] @ R.T
        params = dataclasses.replace(
            params, bed_angle=params.bed_angle + PHI,
            boundaries=tuple(dataclasses.replace(b, normal=tuple(R @ b.normal)) if b.normal else b
                             for b in params.boundaries))
    model = model_class(method).from_config(tagged, cfg, params)
    model.set_velocity(lambda x: np.zeros((2, x.shape[1])))
    report = model.solve_step(2e-3)
    assert report.converged, report.message
    model.accept_step()
    u = model.u_old.x.array.reshape(-1, 2)
    return (u @ R if rotate else u.copy()), model, params


@pytest.mark.parametrize("method", ["regularized", "augmented_lagrangian"])
def test_rotated_scene_gives_the_rotated_answer(method):
    along_axes, _, _ = first_step(method, rotate=False)
    rotated, model, params = first_step(method, rotate=True)
    comm = MPI.COMM_WORLD
    scale = comm.allreduce(float(np.abs(along_axes).max()), op=MPI.MAX)
    difference = comm.allreduce(float(np.abs(rotated - along_axes).max()), op=MPI.MAX)
    squares = comm.allreduce(float(np.sum((rotated - along_axes) ** 2)), op=MPI.SUM)
    norms = comm.allreduce(float(np.sum(along_axes ** 2)), op=MPI.SUM)
    assert scale > 1e-3                       # the mass moves in the first step
    assert difference < 0.02 * scale, (difference, scale)
    assert math.sqrt(squares / norms) < 0.01
    model.destroy()


def test_mesh_velocity_slides_along_slanted_sides():
    _, model, params = first_step("regularized", rotate=True)
    motion = MeshMotion(model, 1.0)
    motion.compute()
    ft = model.tagged.facet_tags
    w = model.mesh_velocity.x.array.reshape(-1, 2)
    from dolfinx import fem
    for b in params.of_kind(*SOLID):
        nodes = fem.locate_dofs_topological(model.Vw, 1, ft.indices[ft.values == b.tag])
        assert np.abs(w[nodes] @ np.asarray(b.normal)).max(initial=0.0) < 1e-12
    assert MPI.COMM_WORLD.allreduce(float(np.abs(w).max(initial=0.0)), op=MPI.MAX) > 0
    motion.solver.destroy()
    model.destroy()
