"""model.grain_pressure (issue 27, docs/benchmarks/2026-12-04-grain-pressure.md): with
``effective`` the grains' friction sees p − p_a, p_a = ρ_a f·(x − x_ref) the light fluid's
hydrostatic pressure, zero at the domain's highest point; ``total`` (the default) keeps p. Checked on a
tiny mesh against hand values, on
the two-phase model built from a config (x_ref on the open top, the yield stress of a light
fluid at rest zero), and the key's default and refusal."""

import math

import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.forms.two_phase import GRAIN_PRESSURES, grain_pressure
from tests.helpers import ROOT, refusal_message, simulation

CONFIG = ROOT / "configs" / "column_eulerian_a1.42.yaml"
LENGTH, HEIGHT = 0.3, 0.2
RHO_A, G = 15.0, 9.81


@pytest.fixture(scope="module")
def mesh():
    return compat.create_rectangle(MPI.COMM_SELF, (0, 0), (LENGTH, HEIGHT), (3, 2))


def _integral(expression, mesh):
    return fem.assemble_scalar(fem.form(expression * ufl.dx(domain=mesh)))


def _pressure(mesh, function):
    p = fem.Function(compat.scalar_space(mesh, 1))
    p.interpolate(lambda x: function(x[0], x[1]))
    return p


def test_effective_pressure_by_hand(mesh):
    """p = ρ_a g (H − y) + 100 Pa (P1 interpolates it exactly): effective p − p_a = 100 Pa
    everywhere, total p integrates to ρ_a g L H²/2 + 100 L H."""
    p = _pressure(mesh, lambda x, y: RHO_A * G * (HEIGHT - y) + 100.0)
    f = ufl.as_vector((0.0, -G))
    effective = grain_pressure(p, RHO_A, f, (0.0, HEIGHT), mesh, "effective")
    total = grain_pressure(p, RHO_A, f, (0.0, HEIGHT), mesh, "total")
    area = LENGTH * HEIGHT
    assert _integral(effective, mesh) / area == pytest.approx(100.0, rel=1e-12)
    assert _integral((effective - 100.0) ** 2, mesh) == pytest.approx(0.0, abs=1e-18)
    assert _integral(total, mesh) == pytest.approx(RHO_A * G * LENGTH * HEIGHT ** 2 / 2
                                                   + 100.0 * area, rel=1e-12)
    # a tilted body force: p_a follows f·x, zero at x_ref
    g = (G * math.sin(0.3), -G * math.cos(0.3))
    tilted = _pressure(mesh, lambda x, y: RHO_A * (g[0] * (x - LENGTH) + g[1] * (y - HEIGHT)))
    rest = grain_pressure(tilted, RHO_A, ufl.as_vector(g), (LENGTH, HEIGHT), mesh, "effective")
    assert _integral(rest ** 2, mesh) == pytest.approx(0.0, abs=1e-18)
    with pytest.raises(ValueError, match="effective, total"):
        grain_pressure(p, RHO_A, f, (0.0, HEIGHT), mesh, "contact")


@pytest.mark.parametrize("kind", GRAIN_PRESSURES)
def test_the_model_measures_from_its_open_top(kind, tmp_path):
    """The two-phase model of the a = 1.42 column (2 cm): x_ref is on the box's open top
    (y = box_height), and under the light fluid's hydrostatic pressure at rest the grains'
    yield stress is zero with ``effective`` (ρ_a g h_a · √2 μ_s with ``total``)."""
    over = ["geometry.mesh_size=0.02", f"model.grain_pressure={kind}", f"model.air_density={RHO_A}"]
    cfg = load_config(CONFIG, over)
    flow = simulation(CONFIG, over, tmp_path, comm=MPI.COMM_SELF).disc.flow
    top = cfg.model.box_height
    assert flow.highest[1] == pytest.approx(top, abs=1e-12)
    pressure = fem.Function(flow.Q)
    pressure.interpolate(lambda x: RHO_A * cfg.material.gravity * (top - x[1]))
    flow.iterate.x.array[flow.pressure_dofs] = pressure.x.array
    yield_stress = flow.params.rheology.yield_stress(flow.grain_pressure)
    got = _integral(yield_stress, flow.mesh)
    if kind == "effective":
        assert abs(got) < 1e-9
    else:
        exact = (
            math.sqrt(2)
            * cfg.material.mu_s
            * RHO_A
            * cfg.material.gravity
            * cfg.model.box_length
            * top**2
            / 2
        )
        assert got == pytest.approx(exact, rel=1e-6)


def test_the_key_defaults_to_effective(capsys):
    assert load_config(CONFIG).model.grain_pressure == "effective"
    assert load_config(CONFIG, ["model.grain_pressure=total"]).model.grain_pressure == "total"
    message = refusal_message(CONFIG, "model.grain_pressure=contact", "model.grain_pressure", capsys)
    assert all(name in message for name in GRAIN_PRESSURES)
