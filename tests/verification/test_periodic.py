"""The periodic constraint, both implementations (dolfinx_mpc's ``PeriodicLinearSystem``
where it is installed, and ``PeriodicPetscSystem``, Pᵀ A P with PETSc alone): a periodic
Stokes channel on an inclined bed [0, L] × [0, h].

Slope coordinates, f = g (sin θ, −cos θ), no-slip bed, stress-free top, periodic in x for
velocity and pressure. The steady solution u = (ρ g sinθ (h y − y²/2)/η, 0),
p = ρ g cosθ (h − y) lies in Taylor–Hood P2/P1, so it is reproduced to round-off; without
the constraint (stress-free sides) it is not.
"""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.rheology.drucker_prager import strain_rate
from dpcollapse.solvers.assembly import LinearSystem
from dpcollapse.solvers.linear import DirectSolver
from dpcollapse.solvers.periodic import PERIODIC_ENV, leaf_subspaces, periodic_system

LENGTH, HEIGHT = 0.2, 0.05
NX, NY = 16, 4
LEFT, RIGHT, BOTTOM, TOP = 1, 2, 3, 4
RHO, G, ETA, THETA = 1500.0, 9.81, 2.0, math.radians(30.0)


try:
    import dolfinx_mpc  # noqa: F401
    HAVE_MPC = True
except ImportError:   # the pip path: only the PETSc implementation
    HAVE_MPC = False


@pytest.fixture(autouse=True, params=["dolfinx_mpc", "petsc"])
def backend(request, monkeypatch):
    """Every test of this file with each implementation of the constraint."""
    if request.param == "dolfinx_mpc" and not HAVE_MPC:
        pytest.skip("dolfinx_mpc is not installed (pip path)")
    monkeypatch.setenv(PERIODIC_ENV, request.param)
    return request.param


def u_exact(x):
    return np.vstack([RHO * G * math.sin(THETA) * (HEIGHT * x[1] - x[1] ** 2 / 2) / ETA,
                      np.zeros_like(x[0])])


def p_exact(x):
    return RHO * G * math.cos(THETA) * (HEIGHT - x[1])


class Channel:
    """Mesh, facet tags, Taylor–Hood space and the (optionally transient) Stokes forms."""

    def __init__(self, comm, dt=None):
        self.mesh = m = compat.create_rectangle(comm, (0.0, 0.0), (LENGTH, HEIGHT), (NX, NY))
        sides = ((LEFT, lambda x: np.isclose(x[0], 0.0)),
                 (RIGHT, lambda x: np.isclose(x[0], LENGTH)),
                 (BOTTOM, lambda x: np.isclose(x[1], 0.0)),
                 (TOP, lambda x: np.isclose(x[1], HEIGHT)))
        indices, values = [], []
        for tag, where in sides:
            facets = dmesh.locate_entities_boundary(m, 1, where)
            indices.append(facets)
            values.append(np.full(len(facets), tag, dtype=np.int32))
        self.facet_tags = compat.meshtags(m, 1, np.concatenate(indices), np.concatenate(values))

        self.W = W = compat.taylor_hood_space(m)
        self.V, vdofs = compat.collapse(W.sub(0))
        self.Q, pdofs = compat.collapse(W.sub(1))
        self.vdofs, self.pdofs = np.asarray(vdofs), np.asarray(pdofs)
        self.u_old = fem.Function(self.V)
        (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
        f = fem.Constant(m, np.array([G * math.sin(THETA), -G * math.cos(THETA)],
                                     dtype=compat.ScalarType))
        rho = fem.Constant(m, compat.ScalarType(RHO))
        self.a = (2 * ETA * ufl.inner(strain_rate(u), strain_rate(v))
                  - p * ufl.div(v) - q * ufl.div(u)) * ufl.dx
        self.L = rho * ufl.inner(f, v) * ufl.dx
        if dt is not None:
            self.dt = fem.Constant(m, compat.ScalarType(dt))
            self.a += rho / self.dt * ufl.inner(u, v) * ufl.dx
            self.L += rho / self.dt * ufl.inner(self.u_old, v) * ufl.dx

    def bed_bc(self, component=None):
        """u = 0 (or one component = 0) on the bed y = 0."""
        bed = self.facet_tags.indices[self.facet_tags.values == BOTTOM]
        sub = self.W.sub(0) if component is None else self.W.sub(0).sub(component)
        Vs, _ = compat.collapse(sub)
        dofs = fem.locate_dofs_topological((sub, Vs), 1, bed)
        return fem.dirichletbc(fem.Function(Vs), dofs, sub)

    def periodic(self, bcs, translation=(-LENGTH, 0.0)):
        return periodic_system(self.a, self.L, bcs, self.W, self.facet_tags, RIGHT, translation)

    def split(self, w):
        """(velocity, pressure) local arrays (owned + ghosts) of a Function on W."""
        return w.x.array[self.vdofs], w.x.array[self.pdofs]


def solve_once(system, solver, target):
    A = system.assemble_matrix()
    system.assemble_vector()
    solver.set_operator(A)
    system.solve(solver, target)


def exact_arrays(ch):
    ue, pe = fem.Function(ch.V), fem.Function(ch.Q)
    ue.interpolate(u_exact)
    pe.interpolate(p_exact)
    return ue.x.array, pe.x.array


def solve_channel(comm):
    ch = Channel(comm)
    system = ch.periodic([ch.bed_bc()])
    solver = DirectSolver(comm, "mumps", prefix="test_periodic_")
    w = fem.Function(ch.W)
    solve_once(system, solver, w)
    system.destroy()
    solver.destroy()
    return ch, w


def test_leaf_subspaces_of_taylor_hood():
    ch = Channel(MPI.COMM_SELF)
    leaves = leaf_subspaces(ch.W)
    assert [tuple(S.component()) for S in leaves] == [(0, 0), (0, 1), (1,)]
    assert leaf_subspaces(ch.Q) == [ch.Q]


def test_periodic_stokes_channel_is_exact():
    """Velocity and pressure to round-off; x = 0 and x = L agree; the no-slip corners hold."""
    ch, w = solve_channel(MPI.COMM_SELF)
    u, p = ch.split(w)
    ue, pe = exact_arrays(ch)
    assert np.max(np.abs(u - ue)) <= 1e-10 * np.max(np.abs(ue))
    assert np.max(np.abs(p - pe)) <= 1e-10 * np.max(np.abs(pe))

    X = ch.V.tabulate_dof_coordinates()
    left, right = np.isclose(X[:, 0], 0.0), np.isclose(X[:, 0], LENGTH)
    order_l, order_r = np.argsort(X[left, 1]), np.argsort(X[right, 1])
    np.testing.assert_allclose(X[left, 1][order_l], X[right, 1][order_r], atol=1e-12)
    ux, uy = u[0::2], u[1::2]
    np.testing.assert_allclose(ux[left][order_l], ux[right][order_r], rtol=1e-12, atol=0)
    corners = np.isclose(X[:, 1], 0.0) & (left | right)
    assert corners.sum() == 2
    assert np.all(ux[corners] == 0.0) and np.all(uy[corners] == 0.0)

    # Control: without the constraint (stress-free sides) the parabola is not the solution.
    system = LinearSystem(ch.a, ch.L, [ch.bed_bc()])
    solver = DirectSolver(MPI.COMM_SELF, "mumps", prefix="test_periodic_ctl_")
    free = fem.Function(ch.W)
    solver.set_operator(system.assemble_matrix())
    solver.solve(system.assemble_vector(), compat.petsc_vec(free))
    assert np.max(np.abs(ch.split(free)[0] - ue)) > 1e-3 * np.max(np.abs(ue))
    system.destroy()
    solver.destroy()


def test_translation_of_wrong_sign_is_rejected():
    ch = Channel(MPI.COMM_SELF)
    with pytest.raises(ValueError, match="translation"):
        ch.periodic([ch.bed_bc()], (LENGTH, 0.0))


def _shift_classes(X):
    """Dof classes of equal (y, x mod Δx): the mesh is invariant under a one-cell shift."""
    dx, dy = LENGTH / NX, HEIGHT / NY
    key = np.round(np.c_[X[:, 1] / dy * 8, np.mod(X[:, 0] + 1e-9 * dx, dx) / dx * 8]).astype(int)
    return np.unique(key, axis=0, return_inverse=True)[1].ravel()


def test_transient_from_rest_is_shift_invariant():
    """Backward Euler from rest, 4 steps: the unique discrete solution inherits the mesh's
    one-cell translation symmetry only through periodicity (the sides would break it)."""
    comm = MPI.COMM_SELF
    ch = Channel(comm, dt=1e-3)
    system = ch.periodic([ch.bed_bc()])
    solver = DirectSolver(comm, "mumps", prefix="test_periodic_tr_")
    w = fem.Function(ch.W)
    classes = _shift_classes(ch.V.tabulate_dof_coordinates())
    speed = []
    for _ in range(4):
        solve_once(system, solver, w)
        ch.u_old.x.array[:] = w.x.array[ch.vdofs]      # coefficient on the collapsed space
        u = ch.u_old.x.array
        scale = np.max(np.abs(u))
        for comp in (0, 1):
            vals = u[comp::2]
            spread = max(np.ptp(vals[classes == c]) for c in np.unique(classes))
            assert spread <= 1e-10 * scale
        speed.append(scale)
    ue, _ = exact_arrays(ch)
    assert np.all(np.diff(speed) > 0) and speed[-1] < np.max(np.abs(ue))
    system.destroy()
    solver.destroy()


def test_transient_free_slip_bed_accelerates_uniformly():
    """u_y = 0 on the bed only (u_x free, so the bed corners' u_x are slaves while their u_y
    keep the bc): backward Euler gives exactly u_x = n Δt g sinθ, p = ρ g cosθ (h − y)."""
    comm = MPI.COMM_SELF
    dt = 1e-2
    ch = Channel(comm, dt=dt)
    system = ch.periodic([ch.bed_bc(component=1)])
    solver = DirectSolver(comm, "mumps", prefix="test_periodic_fs_")
    w = fem.Function(ch.W)
    _, pe = exact_arrays(ch)
    for n in range(1, 4):
        solve_once(system, solver, w)
        ch.u_old.x.array[:] = w.x.array[ch.vdofs]
        u, p = ch.split(w)
        np.testing.assert_allclose(u[0::2], n * dt * G * math.sin(THETA), rtol=1e-10)
        assert np.max(np.abs(u[1::2])) <= 1e-10 * n * dt * G
        assert np.max(np.abs(p - pe)) <= 1e-10 * np.max(np.abs(pe))
    system.destroy()
    solver.destroy()


@pytest.mark.mpi
def test_periodic_channel_in_parallel(comm):
    """On any number of ranks: global L2 norms of u and p match the analytic ones, and every
    local value (owned and ghost) of the target Function is exact."""
    ch, w = solve_channel(comm)
    u, p = ch.split(w)
    ue, pe = exact_arrays(ch)
    assert np.max(np.abs(u - ue), initial=0.0) <= 1e-10 * RHO * G * HEIGHT**2 / ETA
    assert np.max(np.abs(p - pe), initial=0.0) <= 1e-10 * RHO * G * HEIGHT

    uh, ph = (w.sub(i).collapse() for i in (0, 1))   # Functions, not spaces

    def norm(form):
        return math.sqrt(comm.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM))

    u_norm = norm(ufl.inner(uh, uh) * ufl.dx)
    p_norm = norm(ph * ph * ufl.dx)
    u_ref = RHO * G * math.sin(THETA) / ETA * math.sqrt(LENGTH * 2 * HEIGHT**5 / 15)
    p_ref = RHO * G * math.cos(THETA) * math.sqrt(LENGTH * HEIGHT**3 / 3)
    assert u_norm == pytest.approx(u_ref, rel=1e-10)
    assert p_norm == pytest.approx(p_ref, rel=1e-10)
