"""model.viscosity_average (issue 27, docs/benchmarks/2026-12-04-light-fluid.md): the
arithmetic and harmonic mixtures of the granular and the light viscosity assembled on a
tiny mesh against hand values, the harmonic one finite where the granular viscosity
vanishes, the default, and a bad value refused with one line."""

import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.forms.two_phase import MixtureRheology, viscosity_mixture
from dpcollapse.rheology.drucker_prager import DruckerPrager
from tests.helpers import ROOT, refusal_message

CONFIG = ROOT / "configs" / "column_eulerian_a1.42.yaml"
AREA = 0.3 * 0.2


def _mean_secant(law, mesh):
    """S at u = 0, p = 0 integrated over the mesh, divided by its area (S is constant)."""
    u = fem.Function(compat.vector_space(mesh, 1))
    p = fem.Function(compat.scalar_space(mesh, 1))   # p = 0: no yield stress
    form = fem.form(law.secant_viscosity(u, p, 1e-3) * ufl.dx(domain=mesh))
    return fem.assemble_scalar(form) / AREA


@pytest.fixture(scope="module")
def mesh():
    return compat.create_rectangle(MPI.COMM_SELF, (0, 0), (0.3, 0.2), (3, 2))


def test_harmonic_and_arithmetic_secant_viscosity_by_hand(mesh):
    """c = 0.25, S_g = 2η = 4 Pa s, 2η_a = 0.02 Pa s: arithmetic 0.25·4 + 0.75·0.02,
    harmonic 1/(0.25/4 + 0.75/0.02) = 1/37.5625."""
    c = fem.Constant(mesh, compat.ScalarType(0.25))
    granular = DruckerPrager(2.0, 0.5, 0.0)
    arithmetic = _mean_secant(MixtureRheology(granular, c, 1e-2), mesh)
    assert arithmetic == pytest.approx(0.25 * 4.0 + 0.75 * 2e-2, rel=1e-12)
    harmonic = _mean_secant(MixtureRheology(granular, c, 1e-2, "harmonic"), mesh)
    assert harmonic == pytest.approx(1.0 / 37.5625, rel=1e-12)
    # the rate viscosity follows the same average with η_a: 1/(0.25/2 + 0.75/0.01)
    u = fem.Function(compat.vector_space(mesh, 1))
    p = fem.Function(compat.scalar_space(mesh, 1))
    law = MixtureRheology(granular, c, 1e-2, "harmonic")
    eta = fem.assemble_scalar(fem.form(law.rate_viscosity(u, p, 1e-3) * ufl.dx(domain=mesh)))
    assert eta / AREA == pytest.approx(1.0 / (0.25 / 2.0 + 0.75 / 1e-2), rel=1e-12)


@pytest.mark.parametrize("fraction, expected", [(0.0, 2e-2), (1.0, 0.0), (0.5, 0.0)])
def test_harmonic_is_finite_where_the_granular_viscosity_vanishes(mesh, fraction, expected):
    """S_g = 0 (p = 0, η = 0: no strength at the surface): the harmonic mean is the light
    fluid's 2η_a at c = 0 and (to the floor) 0 for c > 0, never 0/0."""
    c = fem.Constant(mesh, compat.ScalarType(fraction))
    S = _mean_secant(MixtureRheology(DruckerPrager(0.0, 0.5, 0.0), c, 1e-2, "harmonic"), mesh)
    assert S == pytest.approx(expected, abs=1e-12)


def test_unknown_average_refused_in_the_form():
    with pytest.raises(ValueError, match="geometric"):
        viscosity_mixture(0.5, 1.0, 2.0, "geometric")


def test_the_key_defaults_to_arithmetic():
    assert load_config(CONFIG).model.viscosity_average == "arithmetic"
    assert load_config(CONFIG, ["model.viscosity_average=harmonic"]).model.viscosity_average == "harmonic"


def test_a_bad_average_is_one_line(capsys):
    message = refusal_message(CONFIG, "model.viscosity_average=geometric",
                              "model.viscosity_average", capsys)
    assert "arithmetic" in message and "harmonic" in message
