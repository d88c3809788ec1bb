"""model.yield_weighting (issue 27, docs/benchmarks/2026-12-04-two-phase-yield-weighting.md):
the mixture's yield stress w(c) κ(p) and its secant viscosity assembled on a tiny mesh
against hand values for each weighting, the default (volume: today's forms unchanged), and a
bad value refused with one line."""

import math

import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.forms.two_phase import YIELD_WEIGHTINGS, MixtureRheology, yield_weight
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI
from tests.helpers import ROOT, refusal_message

CONFIG = ROOT / "configs" / "column_eulerian_a1.42.yaml"
AREA = 0.3 * 0.2
PRESSURE, EPSILON = 100.0, 1e-3
#: η = 2 Pa s, μ_s = 0.5: κ(100 Pa) = √2 · 50 Pa
LAW = DruckerPrager(2.0, 0.5, 0.0)
KAPPA = math.sqrt(2.0) * 0.5 * PRESSURE


@pytest.fixture(scope="module")
def mesh():
    return compat.create_rectangle(MPI.COMM_SELF, (0, 0), (0.3, 0.2), (3, 2))


def _mean(expression, mesh):
    return fem.assemble_scalar(fem.form(expression * ufl.dx(domain=mesh))) / AREA


def _fields(mesh):
    """u = 0 (|D|_ε = ε), p = PRESSURE."""
    u = fem.Function(compat.vector_space(mesh, 1))
    p = fem.Function(compat.scalar_space(mesh, 1))
    p.x.array[:] = PRESSURE
    return u, p


WEIGHTS = {  # c -> w(c) by hand
    "volume": {0.0: 0.0, 0.25: 0.25, 0.5: 0.5, 0.75: 0.75, 1.0: 1.0},
    "sharp": {0.0: 0.0, 0.25: 0.0, 0.5: 1.0, 0.75: 1.0, 1.0: 1.0},
    "saturated": {0.0: 0.0, 0.25: 0.5, 0.5: 1.0, 0.75: 1.0, 1.0: 1.0},
    "grains": {0.0: 0.0, 0.25: 1.0, 0.5: 1.0, 0.75: 1.0, 1.0: 1.0},
}


def test_every_weighting_has_hand_values():
    assert set(WEIGHTS) == set(YIELD_WEIGHTINGS)


@pytest.mark.parametrize("weighting", YIELD_WEIGHTINGS)
@pytest.mark.parametrize("fraction", [0.0, 0.25, 0.5, 0.75, 1.0])
def test_yield_stress_and_secant_viscosity_follow_the_key(mesh, weighting, fraction):
    """κ_mix = w(c) κ(p) and (arithmetic) S = w(c) κ/ε + c 2η + (1 − c) 2η_a at u = 0."""
    c = fem.Constant(mesh, compat.ScalarType(fraction))
    law = MixtureRheology(LAW, c, 1e-2, yield_weighting=weighting)
    u, p = _fields(mesh)
    w = WEIGHTS[weighting][fraction]
    assert _mean(law.yield_stress(p), mesh) == pytest.approx(w * KAPPA, rel=1e-12, abs=1e-12)
    S = w * KAPPA / EPSILON + fraction * 4.0 + (1.0 - fraction) * 2e-2
    assert _mean(law.secant_viscosity(u, p, EPSILON), mesh) == pytest.approx(S, rel=1e-12)


@pytest.mark.parametrize("fraction, expected", [(0.0, 0.0), (1e-13, 1e-7), (5e-7, 0.5),
                                                (1e-6, 1.0), (2e-6, 1.0)])
def test_grains_rises_continuously_over_the_haze(mesh, fraction, expected):
    """grains: w = min(1, c/10⁻⁶), continuous: a round-off change δc of a haze cell moves w by
    at most 10⁶ δc (the step H(c − 10⁻¹²) flipped between 1 and 2 ranks)."""
    c = fem.Constant(mesh, compat.ScalarType(fraction))
    assert _mean(yield_weight(c, "grains"), mesh) == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_volume_is_the_law_s_own_secant_viscosity(mesh):
    """The default builds the very same UFL as before the key: c S_g + (1 − c) 2η_a."""
    c = fem.Constant(mesh, compat.ScalarType(0.3))
    u, p = _fields(mesh)
    expected = 0.3 * LAW.secant_viscosity(u, p, EPSILON) + 0.7 * 2e-2
    got = MixtureRheology(LAW, c, 1e-2).secant_viscosity(u, p, EPSILON)
    assert _mean(got, mesh) == pytest.approx(_mean(expected, mesh), rel=1e-14)


def test_the_cap_applies_to_the_granular_part(mesh):
    """μ(I) with η_max: S = c min(w/c κ/ε + 2η_μI, 2η_max) + (1 − c) 2η_a; at u = 0 the
    yield part is far above the cap, so S = c 2η_max + (1 − c) 2η_a for w > 0 and the
    uncapped 2η_μI part alone where w = 0 (sharp, c = 0.25)."""
    mui = MuI(mu_s=0.32, mu_2=0.6, I0=0.4, grain_diameter=2e-3, grain_density=2500.0,
              viscosity_cap=50.0)
    u, p = _fields(mesh)
    for weighting, fraction in (("saturated", 0.25), ("sharp", 0.75)):
        c = fem.Constant(mesh, compat.ScalarType(fraction))
        S = MixtureRheology(mui, c, 1e-2, yield_weighting=weighting).secant_viscosity(u, p, EPSILON)
        assert _mean(S, mesh) == pytest.approx(fraction * 100.0 + (1 - fraction) * 2e-2, rel=1e-12)
    c = fem.Constant(mesh, compat.ScalarType(0.25))
    S = MixtureRheology(mui, c, 1e-2, yield_weighting="sharp").secant_viscosity(u, p, EPSILON)
    eta = _mean(mui.rate_viscosity(u, p, EPSILON), mesh)
    assert _mean(S, mesh) == pytest.approx(0.25 * 2.0 * min(eta, 50.0) + 0.75 * 2e-2, rel=1e-12)


def test_unknown_weighting_refused_in_the_form():
    with pytest.raises(ValueError, match="hard"):
        yield_weight(0.5, "hard")
    with pytest.raises(ValueError, match="volume, sharp"):
        MixtureRheology(LAW, 0.5, 1e-2, yield_weighting="hard")


def test_the_key_defaults_to_grains():
    assert load_config(CONFIG).model.yield_weighting == "grains"
    assert load_config(CONFIG, ["model.yield_weighting=sharp"]).model.yield_weighting == "sharp"


def test_a_bad_weighting_is_one_line(capsys):
    message = refusal_message(CONFIG, "model.yield_weighting=hard", "model.yield_weighting", capsys)
    assert all(name in message for name in YIELD_WEIGHTINGS)
