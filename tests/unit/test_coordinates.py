"""``rheology.coordinates`` and ``geometry.symmetry``: the (r, z) kinematics and measure, the
laws seeing the hoop rate, the planar forms unchanged, and the key's check-time refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.errors import ConfigError
from dpcollapse.forms import momentum
from dpcollapse.forms.picard import picard_terms
from dpcollapse.rheology.coordinates import AXISYMMETRIC, PLANAR, coordinates
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI
from tests.helpers import ROOT


def _square():
    return compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (4, 4))


def _extension(msh):
    """u = (r, −2z): uniaxial extension, D = diag(1, −2, 1) with the hoop rate u_r/r = 1,
    ∇·u = 1 + 1 − 2 = 0 in (r, z); in the plane D = diag(1, −2) and div u = −1."""
    u = fem.Function(compat.vector_space(msh, 2))
    u.interpolate(lambda x: np.vstack([x[0], -2.0 * x[1]]))
    return u


def _integral(expr, msh, coords):
    return fem.assemble_scalar(fem.form(expr * coords.measure(ufl.dx(domain=msh), msh)))


def test_the_measure_is_the_body_of_revolution():
    """∫ 1 · 2πr dx over [0, 1]² is the unit cylinder's volume π; planar, the area 1."""
    msh = _square()
    assert _integral(1.0, msh, AXISYMMETRIC) == pytest.approx(math.pi, rel=1e-12)
    assert _integral(1.0, msh, PLANAR) == pytest.approx(1.0, rel=1e-12)


def test_strain_rate_has_the_hoop_rate_and_divergence_its_term():
    msh = _square()
    u = _extension(msh)
    D = AXISYMMETRIC.strain_rate(u)
    norm_sq = _integral(ufl.inner(D, D), msh, AXISYMMETRIC) / math.pi
    assert norm_sq == pytest.approx(6.0, rel=1e-12)          # 1 + 4 + 1
    assert _integral(D[2, 2], msh, AXISYMMETRIC) / math.pi == pytest.approx(1.0, rel=1e-12)
    assert abs(_integral(AXISYMMETRIC.divergence(u), msh, AXISYMMETRIC)) < 1e-12
    assert _integral(ufl.inner(PLANAR.strain_rate(u), PLANAR.strain_rate(u)), msh, PLANAR) \
        == pytest.approx(5.0, rel=1e-12)
    assert _integral(PLANAR.divergence(u), msh, PLANAR) == pytest.approx(-1.0, rel=1e-12)


@pytest.mark.parametrize("law", [
    DruckerPrager(0.5, 0.0, cohesion=3.0, coordinates=AXISYMMETRIC),
    MuI(mu_s=0.32, mu_2=0.6, I0=0.4, grain_diameter=0.002, grain_density=1550.0, cohesion=3.0,
        coordinates=AXISYMMETRIC),
])
def test_the_laws_see_the_hoop_rate(law):
    """The yield part κ/|D|_ε of the secant viscosity with |D|² = 6 (not the plane's 5)."""
    msh = _square()
    u = _extension(msh)
    p = fem.Constant(msh, compat.ScalarType(0.0))
    secant = _integral(law.secant_viscosity(u, p, 1e-9), msh, AXISYMMETRIC) / math.pi
    rate = _integral(2.0 * law.capped_rate_viscosity(u, p, 1e-9), msh, AXISYMMETRIC) / math.pi
    assert secant - rate == pytest.approx(math.sqrt(2.0) * 3.0 / math.sqrt(6.0), rel=1e-9)


def test_planar_forms_are_those_of_before():
    """The planar path builds the same UFL as before the key (same form signatures)."""
    msh = _square()
    W = compat.taylor_hood_space(msh)
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    assert PLANAR.measure(ufl.dx) is ufl.dx
    before = {"viscoplastic": 2.0 * ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx,
              "pressure": -p * ufl.div(v) * ufl.dx, "incompressibility": -q * ufl.div(u) * ufl.dx}
    now = {"viscoplastic": momentum.viscoplastic(2.0, u, v), "pressure": momentum.pressure(p, v),
           "incompressibility": momentum.incompressibility(q, u)}
    for name, form in before.items():
        assert now[name].signature() == form.signature(), name
    # and the axisymmetric forms differ
    assert momentum.pressure(p, v, AXISYMMETRIC.measure(ufl.dx, msh), AXISYMMETRIC).signature() \
        != before["pressure"].signature()


def test_picard_terms_default_to_planar():
    msh = _square()
    W = compat.taylor_hood_space(msh)
    it = fem.Function(W)
    u_k, p_k = ufl.split(it)
    one = fem.Constant(msh, compat.ScalarType(1.0))
    f = fem.Constant(msh, np.array([0.0, -9.81], dtype=compat.ScalarType))
    kwargs = dict(rho=one, dt=one, body_force=f, epsilon=1e-6, epsilon_friction=1e-6, u_iter=u_k,
                  p_iter=p_k, u_old=u_k, mesh_velocity=u_k, trial=ufl.TrialFunctions(W),
                  test=ufl.TestFunctions(W), n=ufl.FacetNormal(msh))
    law = DruckerPrager(1.0, 0.5)
    default, explicit = picard_terms(law, **kwargs), picard_terms(law, coordinates=PLANAR, **kwargs)
    for side in (0, 1):
        assert {k: f.signature() for k, f in default[side].items()} == \
            {k: f.signature() for k, f in explicit[side].items()}


def test_unknown_symmetry_is_refused():
    assert coordinates("axisymmetric") is AXISYMMETRIC and coordinates("planar") is PLANAR
    with pytest.raises(ValueError, match="must be one of planar, axisymmetric"):
        coordinates("spherical")


# ------------------------------------------------------------------ the key
AXI = ["geometry.shape=column", "geometry.symmetry=axisymmetric"]


def _message(overrides) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(None, overrides)
    msg = str(info.value)
    assert msg and "\n" not in msg and "Traceback" not in msg
    return msg


def test_axisymmetric_column_loads():
    cfg = load_config(None, AXI + ["material.friction_angle=30"])
    assert cfg.geometry.coordinates == "axisymmetric"
    assert "cylindrical column" in cfg.geometry.describe()
    assert load_config(None, ["geometry.shape=column"]).geometry.coordinates == "planar"
    assert load_config(None, []).geometry.coordinates == "planar"     # trapezoid: no key


@pytest.mark.parametrize(
    "extra, expected",
    [
        (["geometry.symmetry=cylindrical"], "geometry.symmetry"),
        (
            ["numerics.method=augmented_lagrangian"],
            "geometry.symmetry = 'axisymmetric': only with numerics.method",
        ),
        (["geometry.bed_angle=10"], "geometry.bed_angle = 10"),
        (["boundary.channel_width=0.1"], "boundary.channel_width = 0.1"),
        (["boundary.surface_tension=0.1"], "boundary.surface_tension = 0.1"),
        (["model.name=savage_hutter"], "only with model.name = stokes or two_phase"),
        (
            ["model.name=two_phase", "model.min_cell=0.005", "geometry.mesh_size=0.01"],
            "model.min_cell = 0.005",
        ),
        (["numerics.linear_solver=iterative"], "numerics.linear_solver = 'iterative'"),
    ],
)
def test_unsupported_combinations_are_refused_in_one_line(extra, expected):
    assert expected in _message(AXI + extra)


def test_the_key_belongs_to_the_column():
    assert "geometry.symmetry" in _message(["geometry.symmetry=axisymmetric"])


def test_axisymmetric_configs_load():
    paths = sorted((ROOT / "configs").glob("column_axi_a*.yaml"))
    assert len(paths) >= 4
    for path in paths:
        assert load_config(path).geometry.coordinates == "axisymmetric"


# ------------------------------------------------------------------ remeshing's volume
def test_signed_volume_is_the_body_of_revolution():
    """The rectangle [0, R] × [0, H] revolves into the cylinder π R² H; a rectangle off the
    axis [a, b] × [0, H] into the tube π (b² − a²) H; the triangle (0,0), (R,0), (0,H) into
    the cone π R² H/3."""
    from dpcollapse.geometry.polygon import signed_volume

    R, H, a = 0.1, 0.05, 0.03
    assert signed_volume(np.array([[0, 0], [R, 0], [R, H], [0, H]])) == pytest.approx(math.pi * R**2 * H)
    assert signed_volume(np.array([[a, 0], [R, 0], [R, H], [a, H]])) == \
        pytest.approx(math.pi * (R**2 - a**2) * H)
    assert signed_volume(np.array([[0, 0], [R, 0], [0, H]])) == pytest.approx(math.pi * R**2 * H / 3)


def test_offset_run_puts_back_a_volume():
    """The free surface of a column moved along its normal to add a volume exactly (to
    round-off); with the area measure it adds that area instead."""
    from dpcollapse.geometry.polygon import offset_run, signed_area, signed_volume

    n = 20
    top = np.c_[np.linspace(0.1, 0.0, n + 1)[1:-1], np.full(n - 1, 0.05)]
    pts = np.vstack([[[0.0, 0.0], [0.1, 0.0], [0.1, 0.05]], top, [[0.0, 0.05]]])
    tags = np.array([1, 2] + [3] * n + [4])   # bed, right side, surface run, axis
    assert len(tags) == len(pts)
    dv = 1e-5
    moved = offset_run(pts, tags, 3, dv, measure=signed_volume)
    assert signed_volume(moved) - signed_volume(pts) == pytest.approx(dv, rel=1e-9)
    moved = offset_run(pts, tags, 3, dv)
    assert signed_area(moved) - signed_area(pts) == pytest.approx(dv, rel=1e-9)


def test_the_moving_domain_remeshes_by_volume_when_axisymmetric():
    from dpcollapse.domain.base import make_domain

    assert make_domain(load_config(None, AXI)).axisymmetric is True
    assert make_domain(load_config(None, ["geometry.shape=column"])).axisymmetric is False


def test_a_remesh_puts_back_the_volume_of_the_body():
    """``ale.remesh.remesh_domain`` on the column's mesh with a dent in its free surface,
    resampled coarser (surface cells 6 cm): with ``axisymmetric`` the body's volume is kept
    (to 1e-12 of it; the area then changes, +3.1e-3), planar the area (measured: the volume
    then changes by −4.5e-3); without ``conserve_area`` both are lost (−1.9e-2 of the volume)."""
    from dpcollapse.ale.remesh import remesh_domain
    from dpcollapse.geometry.mesher import boundary_edges
    from dpcollapse.geometry.polygon import chain_loops, signed_area, signed_volume
    from dpcollapse.scenes.registry import build_mesh

    cfg = load_config(None, AXI + ["geometry.mesh_size=0.02"])
    tagged = build_mesh(cfg, MPI.COMM_SELF)
    x = tagged.mesh.geometry.x
    top = np.isclose(x[:, 1], cfg.geometry.height)
    x[top, 1] -= 0.004 * np.sin(np.pi * x[top, 0] / cfg.geometry.base_length) ** 2   # a dent

    def measures(t):
        loop = chain_loops(*boundary_edges(t))[0].points
        return signed_volume(loop), signed_area(loop)

    def remeshed(**kwargs):
        new, change, _ = remesh_domain(tagged, 0.02, 0.06, 1e-3, **kwargs)
        return measures(new), change

    v0, a0 = measures(tagged)
    (v, a), change = remeshed(conserve_area=True, axisymmetric=True)
    assert abs(v - v0) <= 1e-12 * v0 and abs(change) <= 1e-12 * v0
    assert abs(a - a0) > 1e-3 * a0                       # the polygon did change
    (v, a), change = remeshed(conserve_area=True)
    assert abs(a - a0) <= 1e-12 * a0 and abs(change) <= 1e-12 * a0
    assert abs(v - v0) > 1e-3 * v0                       # the area is not the volume
    (v, a), change = remeshed(axisymmetric=True)
    assert v - v0 == pytest.approx(change, rel=1e-9) and change < -1e-3 * v0
