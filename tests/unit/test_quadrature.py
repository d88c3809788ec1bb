"""numerics.quadrature_degree: the nonlinear terms get the fixed degree, the polynomial ones
keep their exact rule, and the assembled operator changes only by the quadrature error."""

import numpy as np
from mpi4py import MPI

from dpcollapse.config import load_config
from dpcollapse.models.stokes.discretization import StokesDiscretization
from dpcollapse.scenes.registry import build_mesh
from tests.helpers import ROOT

NONLINEAR = ("convection", "viscoplastic", "bed_friction", "wall_friction")
POLYNOMIAL = ("inertia", "pressure", "incompressibility")


def _disc(degree, tagged=None):
    over = ["geometry.mesh_size=0.04", f"numerics.quadrature_degree={'null' if degree is None else degree}",
            "numerics.convection=implicit"]   # the convection in the matrix (lagged: in the rhs)
    cfg = load_config(ROOT / "configs" / "rigid.yaml", over)
    return StokesDiscretization(tagged or build_mesh(cfg, MPI.COMM_SELF), cfg), cfg


def _degrees(form):
    return {integral.metadata().get("quadrature_degree") for integral in form.integrals()}


def test_degree_reaches_the_nonlinear_terms_only():
    disc, _ = _disc(2)
    terms = disc.flow.terms
    assert set(NONLINEAR) <= set(terms)
    for name in NONLINEAR:
        assert _degrees(terms[name]) == {2}, name
    for name in POLYNOMIAL:
        assert _degrees(terms[name]) == {None}, name   # exact: UFL's polynomial degree
    disc.destroy()
    disc, _ = _disc(None)
    assert all(_degrees(f) == {None} for f in disc.flow.terms.values())
    disc.destroy()


def _matrix(degree, tagged):
    """The assembled flow matrix at a sheared, hydrostatically loaded iterate (dense)."""
    disc, cfg = _disc(degree, tagged)
    flow = disc.flow
    from dolfinx import fem

    u = fem.Function(flow.V)
    u.interpolate(lambda x: np.vstack([0.5 * x[1] ** 2 + 0.1 * x[0], -0.1 * x[1]]))
    p = fem.Function(flow.Q)
    rho_g = cfg.material.density * cfg.material.gravity
    p.interpolate(lambda x: rho_g * (cfg.geometry.height - x[1]))
    flow.iterate.x.array[flow.velocity_dofs] = u.x.array
    flow.iterate.x.array[flow.pressure_dofs] = p.x.array
    flow.mesh_velocity.interpolate(lambda x: np.vstack([0.05 * x[0], 0.0 * x[1]]))
    A = flow.system.assemble_matrix()
    dense = A.convert("dense").getDenseArray().copy()
    disc.destroy()
    return dense


def test_fixed_degree_changes_the_operator_by_the_quadrature_error_only():
    cfg = load_config(ROOT / "configs" / "rigid.yaml", ["geometry.mesh_size=0.04"])
    tagged = build_mesh(cfg, MPI.COMM_SELF)
    estimated, low, q4 = (_matrix(d, tagged) for d in (None, 1, 4))
    scale = np.linalg.norm(estimated)
    err4 = np.linalg.norm(q4 - estimated) / scale
    err1 = np.linalg.norm(low - estimated) / scale
    assert 0 < err4 < 1e-3, err4
    assert err1 > 100 * err4   # a low degree is a much worse approximation of the same integrals
