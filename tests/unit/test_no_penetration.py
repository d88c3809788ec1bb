"""No penetration on a slanted side (forms.no_penetration): a rotated half-Poiseuille channel.

The channel [0, L] × [0, H] of a bed inclined at θ, rotated by φ about the origin: a
frictionless bed (u·n = 0 and no tangential stress; slanted by φ, so no velocity component
carries u·n = 0) that carries the weight of the layer, a no-slip lid, the exact profile
prescribed at both ends. In the channel's frame u' = (ρ g sinθ (H² − y'²)/(2η), 0),
p = ρ g cosθ (H − y') (pinned at the origin): Taylor–Hood P2/P1 contains it, so Nitsche's
consistent terms reproduce it to round-off. The penalty alone does not: the bed's normal
stress −p is not zero, and the penalty lets the flow into the bed by ~p h/(γ S).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.forms import momentum
from dpcollapse.forms.no_penetration import nitsche_no_penetration, penalty_no_penetration
from dpcollapse.solvers.assembly import LinearSystem
from dpcollapse.solvers.linear import DirectSolver

LENGTH, HEIGHT, NX, NY = 0.2, 0.05, 12, 4
RHO, G, ETA, THETA = 1500.0, 9.81, 2.0, math.radians(20.0)
SLIP, LID, ENDS = 1, 2, 3


def rotation(phi):
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def exact_velocity(phi):
    R = rotation(phi)

    def u(x):
        local = R.T @ x[:2]                       # channel frame
        speed = RHO * G * math.sin(THETA) * (HEIGHT**2 - local[1] ** 2) / (2 * ETA)
        return R @ np.vstack([speed, np.zeros_like(speed)])
    return u


def channel_velocity_error(phi: float, lid: str, gamma: float = 100.0) -> float:
    """Largest nodal velocity error relative to the largest speed, with the bed's u·n = 0
    imposed by ``lid``: "strong" (only for φ = 0), "nitsche" or "penalty"."""
    mesh = compat.create_rectangle(MPI.COMM_WORLD, (0.0, 0.0), (LENGTH, HEIGHT), (NX, NY))
    sides = ((SLIP, lambda x: np.isclose(x[1], 0.0)), (LID, lambda x: np.isclose(x[1], HEIGHT)),
             (ENDS, lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], LENGTH)))
    indices, values = [], []
    for tag, where in sides:
        facets = dmesh.locate_entities_boundary(mesh, 1, where)
        indices.append(facets)
        values.append(np.full(len(facets), tag, dtype=np.int32))
    order = np.argsort(np.concatenate(indices))
    tags = compat.meshtags(mesh, 1, np.concatenate(indices)[order], np.concatenate(values)[order])
    def on(tag):
        return tags.indices[tags.values == tag]

    R = rotation(phi)
    mesh.geometry.x[:, :2] = mesh.geometry.x[:, :2] @ R.T      # rotate the channel by φ

    W = compat.taylor_hood_space(mesh)
    V, velocity_dofs = compat.collapse(W.sub(0))
    Q, _ = compat.collapse(W.sub(1))
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    viscosity = fem.Constant(mesh, compat.ScalarType(2 * ETA))    # σ' = 2η D
    force = R @ np.array([G * math.sin(THETA), -G * math.cos(THETA)])
    f = fem.Constant(mesh, np.asarray(force, dtype=compat.ScalarType))
    rho = fem.Constant(mesh, compat.ScalarType(RHO))
    n = ufl.FacetNormal(mesh)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    a = (momentum.viscoplastic(viscosity, u, v) + momentum.pressure(p, v)
         + momentum.incompressibility(q, u))
    if lid == "nitsche":
        a += nitsche_no_penetration(viscosity, u, p, v, q, n, ds(SLIP), gamma)
    elif lid == "penalty":
        a += penalty_no_penetration(viscosity, u, v, n, ds(SLIP), gamma)
    L = momentum.gravity(rho, f, v)

    u_exact = fem.Function(V)
    u_exact.interpolate(exact_velocity(phi))
    zero = fem.Function(V)
    bcs = [fem.dirichletbc(u_exact, fem.locate_dofs_topological((W.sub(0), V), 1, on(ENDS)), W.sub(0)),
           fem.dirichletbc(zero, fem.locate_dofs_topological((W.sub(0), V), 1, on(LID)), W.sub(0))]
    if lid == "strong":
        assert phi == 0.0
        zero_y = fem.Function(V)
        bcs.append(fem.dirichletbc(zero_y, fem.locate_dofs_topological(
            (W.sub(0).sub(1), V.sub(1)), 1, on(SLIP)), W.sub(0).sub(1)))
    # the pressure is fixed up to a constant: pin it at the origin (exact value there)
    p_pin = fem.Function(Q)
    p_pin.x.array[:] = RHO * G * math.cos(THETA) * HEIGHT
    corner = fem.locate_dofs_geometrical((W.sub(1), Q), lambda x: np.isclose(x[0], 0) & np.isclose(x[1], 0))
    bcs.append(fem.dirichletbc(p_pin, corner, W.sub(1)))

    system = LinearSystem(a, L, bcs)
    solver = DirectSolver(mesh.comm, "mumps", prefix="test_nitsche_")
    solver.set_operator(system.assemble_matrix())
    solution = fem.Function(W)
    system.solve(solver, target=solution, b=system.assemble_vector())
    uh = solution.x.array[np.asarray(velocity_dofs)]
    error = mesh.comm.allreduce(float(np.max(np.abs(uh - u_exact.x.array))), op=MPI.MAX)
    scale = mesh.comm.allreduce(float(np.max(np.abs(u_exact.x.array))), op=MPI.MAX)
    system.destroy()
    solver.destroy()
    return error / scale


def test_strong_condition_on_the_unrotated_channel_is_exact():
    assert channel_velocity_error(0.0, "strong") < 1e-9


@pytest.mark.parametrize("phi_deg", [0.0, 30.0, 117.0])
@pytest.mark.parametrize("gamma", [10.0, 100.0])
def test_nitsche_reproduces_the_exact_solution_at_any_angle(phi_deg, gamma):
    assert channel_velocity_error(math.radians(phi_deg), "nitsche", gamma) < 1e-9


def test_penalty_alone_is_inconsistent():
    """Measured (φ = 30°): 9.4e-2 at γ = 100, 2.8e-3 at γ = 1e4 (Nitsche: 2e-14 at both)."""
    phi = math.radians(30.0)
    coarse, fine = (channel_velocity_error(phi, "penalty", gamma) for gamma in (1e2, 1e4))
    assert coarse > 1e-2                    # far above round-off: not consistent
    assert fine < coarse / 10               # it only shrinks as γ grows
