"""Both laws implement the Rheology protocol, and nothing outside rheology/ asks which law
it holds (issue 12: no isinstance or getattr on the rheology)."""

import math
import re

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.rheology.base import Rheology
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI
from tests.helpers import ROOT

DP = DruckerPrager(0.7, 0.477, cohesion=3.0)
MU_I = MuI(mu_s=0.32, mu_2=0.6, I0=0.4, grain_diameter=0.002, grain_density=1550.0)
MU_I_CAPPED = MuI(mu_s=0.32, mu_2=0.6, I0=0.4, grain_diameter=0.002, grain_density=1550.0,
                  viscosity_cap=0.05)


@pytest.mark.parametrize("law", [DP, MU_I, MU_I_CAPPED])
def test_laws_implement_the_protocol(law):
    assert isinstance(law, Rheology)


def _mean(expr_of, gamma_dot=2.0, p_value=800.0, eps=1e-6):
    """A scalar UFL quantity of the law for simple shear u = (γ̇ y, 0) at pressure p, as its
    mean over the unit square (it is uniform)."""
    msh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (2, 2))
    u = fem.Function(compat.vector_space(msh, 2))
    u.interpolate(lambda x: np.vstack([gamma_dot * x[1], 0 * x[0]]))
    p = fem.Constant(msh, compat.ScalarType(p_value))
    return fem.assemble_scalar(fem.form(expr_of(u, p, eps) * ufl.dx(domain=msh)))


def test_drucker_prager_split():
    """DP: η constant (a float), no cap, no window; S = κ/|D|_ε + 2η."""
    assert DP.rate_dependent is False and DP.viscosity_cap is None
    assert DP.capped_rate_viscosity(None, None, 1e-6) == 0.7
    assert DP.well_posed_window() is None and DP.diagnostic_fields(None, None, 1e-6) == {}
    # simple shear γ̇ = 2: |D| = γ̇/√2
    S = _mean(DP.secant_viscosity)
    assert S == pytest.approx(math.sqrt(2) * (3.0 + 0.477 * 800.0) / math.sqrt(2.0 + 1e-12) + 1.4,
                              rel=1e-12)


def test_mu_i_capped_rate_viscosity():
    """μ(I): η_μI = Δμ p/(γ̇ + I0 √(p/ρ_s)/d) at |D|_ε ≈ |D|; the cap takes min(η, η_max)."""
    gamma_dot, p = 2.0, 800.0
    eta = 0.28 * p / (gamma_dot + 0.4 * math.sqrt((p + 1e-10) / 1550.0) / 0.002)
    assert MU_I.rate_dependent is True
    assert _mean(MU_I.capped_rate_viscosity) == pytest.approx(eta, rel=1e-9)
    assert _mean(MU_I_CAPPED.capped_rate_viscosity) == pytest.approx(min(eta, 0.05), rel=1e-12)
    assert _mean(MU_I_CAPPED.secant_viscosity) == pytest.approx(0.1, rel=1e-12)  # 2 η_max
    I = _mean(lambda u, p, eps: MU_I.diagnostic_fields(u, p, eps)["inertial_number"])
    assert I == pytest.approx(0.002 * gamma_dot / math.sqrt((p + 1e-10) / 1550.0), rel=1e-9)
    lo, hi = MU_I.well_posed_window()
    assert 0 < lo < hi


def test_no_type_questions_about_the_rheology():
    """Outside dpcollapse/rheology/, no isinstance(…, DruckerPrager|MuI) and no getattr on a
    law (``rheo``, ``law``, ``rheology``)."""
    offenders = []
    pattern = re.compile(r"isinstance\([^)]*(DruckerPrager|MuI)|getattr\((rheo|law|rheology)\b")
    for path in (ROOT / "dpcollapse").rglob("*.py"):
        if "rheology" in path.relative_to(ROOT / "dpcollapse").parts[:1]:
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert not offenders, "\n".join(offenders)


def test_every_law_is_found_by_its_name_and_says_what_other_models_need():
    """A law is one class registered under its ``material.rheology`` (``rheology.choice.LAWS``):
    built from the material section, with its grain scale and its depth-averaged friction."""
    from dpcollapse.config import load_config
    from dpcollapse.models.savage_hutter.setup import _DEPTH_AVERAGED_FRICTION
    from dpcollapse.rheology.choice import LAWS, law_from_material

    assert set(LAWS) == {"drucker_prager", "mu_i"}
    assert set(_DEPTH_AVERAGED_FRICTION) == set(LAWS.values())
    for name, cls in LAWS.items():
        cfg = load_config(ROOT / "configs/rigid.yaml", [f"material.rheology={name}"])
        law = law_from_material(cfg.material)
        assert type(law) is cls and law.name == name
        assert law.grain_scale == (cfg.material.grain_diameter if law.rate_dependent else 0.0)
        assert isinstance(law.describe(), str)


def test_no_branching_on_the_law_name_outside_rheology():
    """The library's models never ask ``material.rheology == "…"``: they ask the law
    (config/'s validators and the validation/ and studies/ drivers, which require a law,
    may)."""
    pattern = re.compile(r"""rheology\s*(==|!=)|(==|!=)\s*["'](mu_i|drucker_prager)["']""")
    offenders = []
    for path in (ROOT / "dpcollapse").rglob("*.py"):
        parts = path.relative_to(ROOT / "dpcollapse").parts
        if parts[0] in ("rheology", "validation", "config"):
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert not offenders, "\n".join(offenders)
