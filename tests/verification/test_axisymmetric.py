"""The axisymmetric forms (``geometry.symmetry: axisymmetric``) against exact solutions in (r, z).

The momentum, pressure and incompressibility terms are those the models sum
(``forms.picard.picard_terms`` / ``forms.newton.residual_terms`` with
``coordinates=AXISYMMETRIC``: measure 2πr dx, D(u) with the hoop rate u_r/r, ∇·u with u_r/r)
on Taylor–Hood P2/P1, steady (the inertia and convection terms left out), with u_r = 0 on
the axis r = 0:

- a manufactured solution (stream function ψ = r² e^{−r²} sin πz: u_r = −r e^{−r²} π cos πz,
  u_z = (2 − 2r²) e^{−r²} sin πz, ∇·u = 0, both smooth on the axis; p = cos πr sin πz) whose
  body force is −∇·σ written in cylindrical components, (∇·σ)_r = ∂_r σ_rr + ∂_z σ_rz +
  (σ_rr − σ_θθ)/r, (∇·σ)_z = ∂_r σ_rz + ∂_z σ_zz + σ_rz/r — not the weak form's own
  terms: orders 3 (velocity) and 2 (pressure) in the L² norm of the body (weight 2πr), for
  a Newtonian fluid and for a regularized Bingham law (whose |D| has the hoop rate);
- the pipe (``reference.pipe``): Hagen–Poiseuille, in P2, to round-off; the Bingham plug
  (Drucker–Prager with μ_s = 0 and cohesion τ_y) by the regularized law, Newton with
  backtracking (``solvers.newton``) and continuation in ε: the error falls as ε (measured,
  largest in the plug, relative to the centre speed: 1.4e-6 at ε = 1e-4 s⁻¹, 1.4e-8 at 1e-6,
  1.4e-10 at 1e-8, on 16 cells across with r_p on a line of nodes).

Each test also runs the same problem in planar coordinates (the forms before the key) and
checks that it misses the exact solution: the test fails without the axisymmetric forms.
"""

import dataclasses
import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.forms.newton import jacobian, residual_terms, with_fixed_quadrature
from dpcollapse.reference.pipe import bingham_pipe, plug_radius, poiseuille_pipe
from dpcollapse.rheology.coordinates import AXISYMMETRIC, PLANAR
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.solvers.assembly import LinearSystem
from dpcollapse.solvers.newton import SnesNewton

ETA = 1.0
TOP = 4


def _exact(x):
    r, z = x[0], x[1]
    u = ufl.as_vector([-r * ufl.exp(-r**2) * math.pi * ufl.cos(math.pi * z),
                       (2 - 2 * r**2) * ufl.exp(-r**2) * ufl.sin(math.pi * z)])
    return u, ufl.cos(math.pi * r) * ufl.sin(math.pi * z)


def _component_bc(W, mesh, where, component=None):
    """u = 0 (or one component = 0) on the boundary facets where ``where`` holds."""
    sub = W.sub(0) if component is None else W.sub(0).sub(component)
    V, _ = compat.collapse(sub)
    facets = dmesh.locate_entities_boundary(mesh, 1, where)
    return fem.dirichletbc(fem.Function(V), fem.locate_dofs_topological((sub, V), 1, facets), sub)


def manufactured_errors(n: int, coordinates=AXISYMMETRIC, law=None, epsilon: float = 0.5):
    """(‖u_h − u‖, ‖p_h − p‖, Newton iterations) in L²(2πr dx) on the unit square of n × n
    cells: u = exact on r = 1 and z = 0, the exact traction σn on z = 1, u_r = 0 on the axis.
    ``law``: Newtonian η = 1 (None) or a viscoplastic law, regularized by ``epsilon`` [1/s]
    (its σ' in (r, z) gives the body force); Newton (``solvers.newton``) on the residual of
    ``forms.newton`` in ``coordinates``."""
    law = law or DruckerPrager(ETA, 0.0)
    m = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (n, n))
    x = ufl.SpatialCoordinate(m)
    r = x[0]
    ue, pe = _exact(x)
    exact_law = dataclasses.replace(law, coordinates=AXISYMMETRIC)
    s = -pe * ufl.Identity(3) + exact_law.deviatoric_stress(ue, pe, epsilon)
    f = -ufl.as_vector([s[0, 0].dx(0) + s[0, 1].dx(1) + (s[0, 0] - s[2, 2]) / r,
                        s[1, 0].dx(0) + s[1, 1].dx(1) + s[1, 0] / r])
    W = compat.taylor_hood_space(m)
    U = fem.Function(W)
    v, q = ufl.TestFunctions(W)
    one = fem.Constant(m, compat.ScalarType(1.0))
    dx = ufl.Measure("dx", domain=m, metadata={"quadrature_degree": 8})
    terms = residual_terms(dataclasses.replace(law, coordinates=coordinates), state=ufl.split(U),
                           test=(v, q), rho=one, dt=one, body_force=f, epsilon=epsilon,
                           epsilon_friction=1e-8, u_old=ufl.split(U)[0],
                           mesh_velocity=ufl.split(U)[0], n=ufl.FacetNormal(m), dx=dx,
                           coordinates=coordinates)
    top = dmesh.locate_entities_boundary(m, 1, lambda X: np.isclose(X[1], 1.0))
    ds = ufl.Measure("ds", domain=m, subdomain_data=compat.meshtags(m, 1, top, np.full(len(top), TOP)),
                     metadata={"quadrature_degree": 8})
    traction = ufl.dot(AXISYMMETRIC.in_plane(s), ufl.FacetNormal(m))
    # the body force at the cells' degree-8 rule (the "gravity" term's own dx would take
    # UFL's estimate for f, thousands of points; the pipe tests that term)
    F = (sum(terms[k] for k in ("viscoplastic", "pressure", "incompressibility"))
         - ufl.inner(f, v) * coordinates.measure(dx, m)
         - ufl.inner(traction, v) * coordinates.measure(ds(TOP), m))
    V, vdofs = compat.collapse(W.sub(0))
    vdofs = np.asarray(vdofs)
    g = fem.Function(V)
    g.interpolate(compat.expression(ue, V))
    outer = dmesh.locate_entities_boundary(m, 1, lambda X: np.isclose(X[0], 1.0) | np.isclose(X[1], 0.0))
    dofs = fem.locate_dofs_topological((W.sub(0), V), 1, outer)
    axis = _component_bc(W, m, lambda X: np.isclose(X[0], 0.0), 0)
    # the iterate starts on the boundary values; the Newton updates vanish there
    fem_petsc.set_bc(compat.petsc_vec(U), [fem.dirichletbc(g, dofs, W.sub(0)), axis])
    U.x.scatter_forward()
    system = LinearSystem(jacobian(with_fixed_quadrature(F), U, ufl.TrialFunction(W)),
                          -with_fixed_quadrature(F),
                          [fem.dirichletbc(fem.Function(V), dofs, W.sub(0)), axis], homogeneous=True)
    last = {"u": U.x.array[vdofs].copy()}

    def converged(_iteration: int) -> bool:
        u = U.x.array[vdofs]
        step = np.max(np.abs(u - last["u"]))
        last["u"] = u.copy()
        return step <= 1e-11 * np.max(np.abs(u))

    newton = SnesNewton(MPI.COMM_SELF, system, U, converged, line_search="bt", max_iterations=50,
                        prefix="test_axi_mms_")
    reason, iterations = newton.solve()
    assert reason > 0, (n, reason, iterations)
    uh, ph = ufl.split(U)
    weight = 2 * math.pi * r
    eu = fem.assemble_scalar(fem.form(ufl.inner(uh - ue, uh - ue) * weight * dx))
    ep = fem.assemble_scalar(fem.form((ph - pe) ** 2 * weight * dx))
    newton.destroy()
    system.destroy()
    return math.sqrt(eu), math.sqrt(ep), iterations


#: the Bingham law of the viscoplastic manufactured solution: η = 1 Pa s, τ_y = 1 Pa (κ = √2),
#: regularized by ε = 0.5 1/s (so that the solution is smooth: the rates are the element's)
BINGHAM = DruckerPrager(ETA, 0.0, cohesion=1.0)


@pytest.mark.parametrize("law, measured", [
    (None, "velocity 9.4e-3, 1.2e-3, 1.4e-4, 1.8e-5 (orders 3.02, 3.02, 3.00), pressure 6.0e-2, "
           "1.3e-2, 2.9e-3, 7.2e-4 (2.26, 2.11, 2.03)"),
    (BINGHAM, "velocity 9.6e-3, 1.2e-3, 1.4e-4, 1.8e-5 (3.06, 3.02, 3.00), pressure 6.4e-2, "
              "1.4e-2, 3.0e-3, 7.2e-4 (2.24, 2.18, 2.06); 6 Newton iterations each"),
], ids=["newtonian", "bingham"])
def test_manufactured_solution_converges_at_taylor_hood_rates(law, measured):
    """Measured (n = 4, 8, 16, 32): see ``measured``. The Bingham law's |D| includes the hoop
    rate: its secant viscosity κ/|D|_ε varies by a factor 2–3 over the domain."""
    errors = [manufactured_errors(n, law=law)[:2] for n in (4, 8, 16, 32)]
    (u16, p16), (u32, p32) = errors[-2:]
    assert 2.9 < math.log2(u16 / u32) < 3.2, errors
    assert 1.9 < math.log2(p16 / p32) < 2.2, errors
    assert u32 < 3e-5 and p32 < 1e-3, errors


@pytest.mark.parametrize("law", [None, BINGHAM], ids=["newtonian", "bingham"])
def test_manufactured_solution_is_missed_by_the_planar_forms(law):
    """Control: the same problem with the planar forms (no 2πr, no hoop rate, div without
    u_r/r) does not converge to the axisymmetric solution (measured: the velocity error stays
    at 0.852 (Newtonian) and 0.847 (Bingham) for n = 8 and 16, against 1.2e-3 and 1.4e-4)."""
    coarse = manufactured_errors(8, PLANAR, law)
    fine = manufactured_errors(16, PLANAR, law)
    assert fine[0] > 1e-2 and fine[0] > 0.5 * coarse[0], (coarse, fine)


# ------------------------------------------------------------------------------- the pipe
R, LENGTH, RHO, G = 0.05, 0.01, 1500.0, 9.81
DRIVING = RHO * G          # G of reference.pipe [Pa/m]: gravity along −z


def pipe_flow(nr: int, law, epsilons=(1e-8,), coordinates=AXISYMMETRIC):
    """Steady flow down the pipe [0, R] × [0, L] (nr cells across, 2 along), gravity −g e_z:
    u = 0 on r = R, u_r = 0 on the axis and on z = 0, L (there u_z is free, the normal stress
    σ_zz = 0 exact for a flow independent of z). Newton (backtracking line search) on the
    residual of ``forms.newton`` for each ε in turn (continuation), each to a velocity step
    below 1e-12 of max |u|. Returns (r of the velocity dofs, u (n, 2), Newton iterations)."""
    m = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (R, LENGTH), (nr, 2))
    W = compat.taylor_hood_space(m)
    U = fem.Function(W)
    epsilon = fem.Constant(m, compat.ScalarType(epsilons[0]))
    terms = residual_terms(
        law, state=ufl.split(U), test=ufl.TestFunctions(W), rho=fem.Constant(m, compat.ScalarType(RHO)),
        dt=fem.Constant(m, compat.ScalarType(1.0)),
        body_force=fem.Constant(m, np.array([0.0, -G], dtype=compat.ScalarType)),
        epsilon=epsilon, epsilon_friction=1e-8, u_old=ufl.split(U)[0],
        mesh_velocity=ufl.split(U)[0], n=ufl.FacetNormal(m), coordinates=coordinates)
    F = with_fixed_quadrature(sum(terms[k] for k in ("viscoplastic", "pressure", "incompressibility",
                                                     "gravity")))
    bcs = [_component_bc(W, m, lambda X: np.isclose(X[0], 0.0) | np.isclose(X[1], 0.0)
                         | np.isclose(X[1], LENGTH), 0),
           _component_bc(W, m, lambda X: np.isclose(X[0], R))]
    system = LinearSystem(jacobian(F, U, ufl.TrialFunction(W)), -F, bcs, homogeneous=True)
    V, vdofs = compat.collapse(W.sub(0))
    vdofs = np.asarray(vdofs)
    last = {"u": U.x.array[vdofs].copy()}

    def converged(_iteration: int) -> bool:
        u = U.x.array[vdofs]
        step = np.max(np.abs(u - last["u"]))
        last["u"] = u.copy()
        return step <= 1e-12 * np.max(np.abs(u))

    newton = SnesNewton(MPI.COMM_SELF, system, U, converged, line_search="bt", max_iterations=100,
                        prefix="test_axi_pipe_")
    iterations = 0
    for eps in epsilons:
        epsilon.value = eps
        last["u"] = U.x.array[vdofs].copy()
        reason, its = newton.solve()
        assert reason > 0, (eps, reason, its)
        iterations += its
    u = U.x.array[vdofs].reshape(-1, 2)
    r = V.tabulate_dof_coordinates()[:, 0]
    newton.destroy()
    system.destroy()
    return r, u, iterations


def test_poiseuille_pipe_is_exact():
    """u_z = −G (R² − r²)/(4η) lies in P2: reproduced to round-off (measured 2.1e-15
    relative on 8 cells across), u_r = 0 (3.7e-16 m/s); the planar forms give the plane
    channel's −G (R² − x²)/(2η), twice as fast (measured ratio 2.000)."""
    law = DruckerPrager(ETA, 0.0, coordinates=AXISYMMETRIC)
    r, u, _ = pipe_flow(8, law)
    exact = poiseuille_pipe(r, R, DRIVING, ETA)
    scale = np.max(np.abs(exact))
    assert np.max(np.abs(u[:, 1] - exact)) <= 1e-10 * scale
    assert np.max(np.abs(u[:, 0])) <= 1e-10 * scale

    r, u, _ = pipe_flow(8, DruckerPrager(ETA, 0.0), coordinates=PLANAR)
    assert np.max(np.abs(u[:, 1] - exact)) > 0.5 * scale


@pytest.fixture(scope="module")
def bingham():
    """The Bingham pipe with the plug radius r_p = R/2 on a line of nodes (16 cells across),
    ε continued 1 → 1e-6 s⁻¹ by decades."""
    tau = DRIVING * R / 4.0
    law = DruckerPrager(ETA, 0.0, cohesion=tau, coordinates=AXISYMMETRIC)
    r, u, iterations = pipe_flow(16, law, [10.0**-k for k in range(7)])
    return tau, r, u, iterations


def test_bingham_plug_in_a_pipe(bingham):
    """Measured at ε = 1e-6 s⁻¹ (82 Newton iterations over the 7 values of ε), relative to the
    centre speed: 1.4e-8 in the plug (its spread 1.4e-8: rigid), 9.6e-11 in the sheared
    annulus; u_r 4.6e-11 m/s."""
    tau, r, u, iterations = bingham
    exact = bingham_pipe(r, R, DRIVING, ETA, tau)
    rp = plug_radius(DRIVING, tau)
    assert rp == pytest.approx(R / 2)
    scale = np.max(np.abs(exact))
    plug, sheared = r <= rp, r > rp
    assert np.max(np.abs(u[plug, 1] - exact[plug])) <= 1e-6 * scale
    assert np.max(np.abs(u[sheared, 1] - exact[sheared])) <= 1e-6 * scale
    # rigid: the plug's speed is one value, to the same accuracy
    assert np.ptp(u[plug, 1]) <= 1e-6 * scale
    assert np.max(np.abs(u[:, 0])) <= 1e-6 * scale
    assert iterations < 200, iterations


def test_bingham_plug_is_missed_without_the_yield_stress(bingham):
    """Control: the Newtonian pipe of the same η runs 4.0 times faster at the centre."""
    tau, r, u, _ = bingham
    exact = bingham_pipe(r, R, DRIVING, ETA, tau)
    newtonian = poiseuille_pipe(r, R, DRIVING, ETA)
    assert np.max(np.abs(newtonian - exact)) > 0.5 * np.max(np.abs(exact))
