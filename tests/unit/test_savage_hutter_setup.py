"""The config → depth-averaged model mapping (models/savage_hutter/setup.py) and the model
factories the loop finds (models/registry.py)."""

import math

import numpy as np
import pytest

from dpcollapse.config import load_config
from dpcollapse.models.registry import model_factories
from dpcollapse.models.savage_hutter.friction import CoulombFriction, MuIFriction
from dpcollapse.models.savage_hutter.setup import basal_friction, domain_end, setup_from_config
from tests.helpers import RIGID_BDF1, ROOT

RIGID = ROOT / "configs" / "rigid.yaml"
SH = ["model.name=savage_hutter", *RIGID_BDF1,   # bdf2 is refused with it,
      "numerics.convection=implicit"]                 # and the moving mesh's lagged convection


def _cfg(*overrides):
    return load_config(RIGID, SH + list(overrides))


def test_the_registry_finds_both_models():
    from dpcollapse.models.savage_hutter.adapter import SavageHutterFactory
    from dpcollapse.models.stokes.discretization import StokesFactory

    found = model_factories()
    assert found["stokes"] is StokesFactory and found["savage_hutter"] is SavageHutterFactory


@pytest.mark.parametrize("overrides, law, mu, source", [
    # the rigid case: bed angle = friction angle, so the layer shears at the material's μ_s
    ((), CoulombFriction, math.tan(math.radians(25.5)), "rheology"),
    (("boundary.bed_friction_angle=20",), CoulombFriction, math.tan(math.radians(20)), "bed"),
    (("boundary.bed_friction_angle=20", "boundary.bed_condition=no_slip"), CoulombFriction,
     math.tan(math.radians(25.5)), "rheology"),
    (("model.basal_friction=bed", "boundary.bed_friction_angle=30"), CoulombFriction,
     math.tan(math.radians(30)), "bed"),
    (("material.rheology=mu_i", "boundary.bed_condition=no_slip"), MuIFriction,
     math.tan(math.radians(25.5)), "rheology"),
])
def test_basal_friction(overrides, law, mu, source):
    friction, got_source = basal_friction(_cfg(*overrides))
    assert isinstance(friction, law) and got_source == source
    assert float(friction.static(np.zeros(1))[0]) == pytest.approx(mu, rel=1e-14)


def test_mu_i_parameters_come_from_the_material():
    cfg = _cfg("material.rheology=mu_i", "model.basal_friction=rheology")
    f, _ = basal_friction(cfg)
    m = cfg.material
    assert (f.mu_s, f.mu_2, f.i0, f.grain_diameter, f.g) == (
        m.mu_s, m.mu_2, m.inertial_number_I0, m.grain_diameter, m.gravity)


def test_trapezoid_mass_slope_and_side_walls():
    cfg = _cfg("geometry.bed_angle=10", "boundary.channel_width=0.1", "model.n_cells=333",
               "model.shape_factor=1.25", "model.order=2", "model.right=wall")
    s = setup_from_config(cfg)
    assert s.model.slope_deg == 10 and s.model.shape_factor == 1.25 and s.model.order == 2
    assert s.model.right == "wall" and s.model.left == "wall"
    assert s.model.side_wall.width == 0.1
    assert s.model.side_wall.mu_w == pytest.approx(math.tan(math.radians(10.2)))
    assert s.area == pytest.approx(cfg.geometry.area, rel=1e-14)
    assert float(np.sum(s.h0) * s.grid.dx) == pytest.approx(s.area, rel=1e-13)
    assert s.grid.n_cells == 333 and s.grid.x_max == domain_end(cfg) == pytest.approx(0.297 + 20 * 0.25)
    assert s.h0.max() == pytest.approx(0.25) and s.h0.min() == 0.0


def test_column_fills_its_cells():
    cfg = load_config(ROOT / "configs" / "column_sh.yaml")
    s = setup_from_config(cfg)
    inside = s.grid.edges[1:] <= cfg.geometry.base_length + 1e-12
    assert np.all(s.h0[inside] == pytest.approx(cfg.geometry.height))
    assert np.all(s.h0[~inside] == 0.0)


@pytest.mark.parametrize("overrides, k_pair", [
    ((), None),                                   # hydrostatic by default: K = 1
    # bed 25.5° = φ → rheology, δ = φ: K_act = K_pass = 1 + 2 tan²φ
    (("model.earth_pressure=savage_hutter",), (1.455011, 1.455011)),
    # the layer slides on a 20° bed (δ = 20°, φ = 25.5°)
    (("model.earth_pressure=savage_hutter", "boundary.bed_friction_angle=20"), (0.771926, 2.138097)),
])
def test_earth_pressure_from_the_config(overrides, k_pair):
    ep = setup_from_config(_cfg(*overrides)).model.earth_pressure
    if k_pair is None:
        assert ep is None
    else:
        assert (ep.k_active, ep.k_passive) == pytest.approx(k_pair, abs=2e-6)


def test_earth_pressure_refuses_a_bed_rougher_than_the_material():
    from dpcollapse.errors import ConfigError

    with pytest.raises(ConfigError, match=r"^boundary.bed_friction_angle = 30.*imaginary"):
        _cfg("model.earth_pressure=savage_hutter", "model.basal_friction=bed",
             "boundary.bed_friction_angle=30")
    _cfg("model.basal_friction=bed", "boundary.bed_friction_angle=30")   # K = 1: allowed
