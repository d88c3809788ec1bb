"""dpcollapse.config: defaults, the shipped configs, one-line errors, overrides, round trip."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from pydantic import ValidationError

from dpcollapse.config import (
    Config,
    config_to_dict,
    load_config,
    save_config,
    validate_config,
    with_overrides,
)
from dpcollapse.errors import ConfigError
from tests.helpers import RIGID_BDF1

ROOT = Path(__file__).resolve().parents[2]
RIGID = ROOT / "configs" / "rigid.yaml"
STABLE = ROOT / "configs" / "stable.yaml"


def _error(tmp_path: Path, text: str | None = None, overrides=()) -> str:
    """The one-line ConfigError message for a config file with ``text`` (None: no file)."""
    path = None
    if text is not None:
        path = tmp_path / "bad.yaml"
        path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(path, overrides)
    msg = str(info.value)
    assert msg and "\n" not in msg, msg
    assert "Traceback" not in msg
    return msg


def test_defaults_load():
    cfg = load_config(None)
    assert isinstance(cfg, Config)
    assert cfg.geometry.height == 0.25 and cfg.material.density == 1550.0
    assert cfg.numerics.linear_solver == "mumps" and cfg.numerics.ale is True
    assert cfg.time.output_every == 20 and cfg.output.directory == Path("runs/rigid")
    assert cfg.geometry.surface_mesh_size is None and cfg.geometry.mesh_file is None


def test_defaults_live_in_the_fields_with_units():
    from dpcollapse.config import GEOMETRIES, MATERIALS, MODELS

    unions = ("geometry", "material", "model")
    sections = [f.annotation for k, f in Config.model_fields.items() if k not in unions]
    for section in (sections + list(GEOMETRIES.values()) + list(MATERIALS.values())
                    + list(MODELS.values())):
        for name, field in section.model_fields.items():
            assert field.description, name


def test_frozen():
    cfg = load_config(None)
    with pytest.raises(ValidationError):
        cfg.material.density = 1.0  # type: ignore[misc]


def test_rigid_yaml():
    cfg = load_config(RIGID)
    assert round(cfg.material.mu_s, 4) == 0.4770
    assert cfg.material.mu_s == pytest.approx(math.tan(math.radians(25.5)))
    assert cfg.boundary.mu_bed == pytest.approx(math.tan(math.radians(25.5)))
    assert cfg.boundary.mu_wall == pytest.approx(math.tan(math.radians(10.2)))
    assert cfg.geometry.top_length == pytest.approx(0.297 - 0.25 / math.tan(math.radians(70)))
    assert cfg.geometry.area == pytest.approx(0.0628, abs=1e-4)
    assert cfg.time.max_steps == 2000
    assert cfg.gravity_vector == pytest.approx((0.0, -9.81))
    # the file spells out the defaults, but for its error-controlled BDF2 step and the
    # lagged convection (LDLᵀ)
    assert (cfg.time.scheme, cfg.time.tolerance, cfg.time.dt_max) == ("bdf2", 3e-4, 0.02)
    assert cfg.time.error_norm == "max"
    assert cfg.numerics.convection == "lagged"
    assert load_config(RIGID, RIGID_BDF1 + ["numerics.convection=implicit",
                                            "time.error_norm=rms"]) == load_config(None)


def test_stable_yaml():
    cfg = load_config(STABLE)
    assert cfg.geometry.flank_angle == 20.0 < cfg.material.friction_angle
    assert cfg.time.end_time == 0.1 and cfg.geometry.top_length > cfg.geometry.mesh_size


def test_quadrature_degree_key():
    """null (UFL's estimate) and integers in range are accepted."""
    assert load_config(None, ["numerics.quadrature_degree=null"]).numerics.quadrature_degree is None
    assert load_config(None, ["numerics.quadrature_degree=6"]).numerics.quadrature_degree == 6


def test_the_fixed_point_stop_follows_the_step_error_tolerance():
    """numerics.nonlinear_atol null: 0.3 × time.tolerance with the error-controlled step,
    1e-7 m/s with a fixed step; a value given is kept; and it reaches the fixed point."""
    from dpcollapse.models.stokes.augmented import augmented_settings
    from dpcollapse.models.stokes.regularized import picard_settings

    rigid = load_config(RIGID)
    assert rigid.numerics.nonlinear_atol is None and rigid.time.tolerance == 3e-4
    # min(0.3 × 3e-4, 0.03 × rest_speed 1e-3): the rest rule's bound
    assert math.isclose(rigid.fixed_point_atol, 3e-5, rel_tol=1e-12)
    assert math.isclose(picard_settings(rigid).atol, 3e-5, rel_tol=1e-12)
    tight = load_config(RIGID, ["time.tolerance=5e-5"])
    assert math.isclose(tight.fixed_point_atol, 1.5e-5, rel_tol=1e-12)
    fixed = load_config(RIGID, RIGID_BDF1)
    assert fixed.fixed_point_atol == 1e-7
    al = load_config(RIGID, RIGID_BDF1 + ["numerics.method=augmented_lagrangian"])
    assert augmented_settings(al).atol == 1e-7
    assert load_config(RIGID, ["numerics.nonlinear_atol=2e-6"]).fixed_point_atol == 2e-6
    assert load_config(RIGID, ["numerics.nonlinear_atol=0"]).fixed_point_atol == 0.0
    assert load_config(None).fixed_point_atol == 1e-7


def test_time_step_keys():
    """dt_max < dt only matters when adaptive."""
    cfg = load_config(None, ["time.dt=1e-2", "time.dt_max=5e-3", "time.adaptive=false"])
    assert cfg.time.dt_max == 5e-3 and not cfg.time.adaptive
    cfg = load_config(None, ["time.adaptive=true", "time.cfl=0.25"])
    assert cfg.time.adaptive and cfg.time.cfl == 0.25


def test_gravity_on_a_slope():
    cfg = load_config(None, ["geometry.bed_angle=30"])
    assert cfg.gravity_vector == pytest.approx((9.81 * 0.5, -9.81 * math.cos(math.radians(30))))


@pytest.mark.parametrize(
    "text, expected",
    [
        ("material:\n  densty: 1500\n", "material.densty: unknown key; did you mean 'density'?"),
        ("materal:\n  density: 1500\n", "materal: unknown section; did you mean 'material'?"),
        ("time:\n  dt: abc\n", "time.dt = 'abc': must be a number"),
        ("time:\n  dt: true\n", "time.dt = true: must be a number"),
        ("time:\n  output_every: 2.5\n", "time.output_every = 2.5: must be an integer"),
        ("numerics:\n  ale: 3\n", "numerics.ale = 3: must be true or false"),
        ("numerics:\n  linear_solver: lu\n", "numerics.linear_solver = 'lu': must be one of"),
        ("model:\n  name: two_phase\n  yield_weighting: hard\n",
         "model.yield_weighting = 'hard': must be one of 'volume', 'sharp', 'saturated' or 'grains'"),
        ("material:\n  density: -3.0\n", "material.density = -3.0: must be > 0 (kg/m^3)"),
        ("material:\n  density: 0\n", "material.density = 0: must be > 0 (kg/m^3)"),
        ("geometry:\n  flank_angle: 95.0\n",
         "geometry.flank_angle = 95.0: must be in (0, 90] degrees"),
        ("material:\n  friction_angle: -1\n",
         "material.friction_angle = -1: must be in [0, 90) degrees"),
        ("material:\n  rheology: mu_i\n  friction_angle: 0\n",
         "material.friction_angle = 0: must be in (0, 90) degrees for mu_i"),
        ("material:\n  friction_angle: 0\n  viscosity: 0\n",
         "material.viscosity = 0: must be > 0 when material.friction_angle"),
        ("boundary:\n  bed_friction_angle: 90\n",
         "boundary.bed_friction_angle = 90: must be in [0, 90) degrees"),
        ("numerics:\n  epsilon: 0.0\n", "numerics.epsilon = 0.0: must be > 0 (1/s)"),
        ("numerics:\n  epsilon: -1.0e-6\n", "numerics.epsilon = -1e-06: must be > 0 (1/s)"),
        ("time:\n  dt: 0\n", "time.dt = 0: must be > 0 (s)"),
        ("time:\n  dt: .inf\n", "time.dt = inf: must be a finite number"),
        ("time:\n  dt: 1.0e-3\n  dt_min: 1.0e-2\n",
         "time.dt_min = 0.01: must be <= time.dt = 0.001 (s)"),
        ("numerics:\n  quadrature_degree: 0\n",
         "numerics.quadrature_degree = 0: must be in [1, 20]"),
        ("numerics:\n  quadrature_degree: 21\n",
         "numerics.quadrature_degree = 21: must be in [1, 20]"),
        ("numerics:\n  quadrature_degree: 4.5\n",
         "numerics.quadrature_degree = 4.5: must be an integer"),
        ("numerics:\n  quadrature_degree: true\n",
         "numerics.quadrature_degree = true: must be an integer"),
        ("time:\n  adaptive: 3\n", "time.adaptive = 3: must be true or false"),
        ("time:\n  cfl: 0\n", "time.cfl = 0: must be in (0, 10]"),
        ("time:\n  cfl: 11\n", "time.cfl = 11: must be in (0, 10]"),
        ("time:\n  dt_max: -1.0\n", "time.dt_max = -1.0: must be > 0 (s)"),
        ("time:\n  adaptive: true\n  dt: 1.0e-2\n  dt_max: 5.0e-3\n",
         "time.dt_max = 0.005: must be >= time.dt = 0.01 (s) with time.adaptive = true"),
        ("geometry:\n  mesh_size: 0.5\n",
         "geometry.mesh_size = 0.5: larger than the mass "
         "(must be < 0.206 m = min(height, top length))"),
        ("geometry:\n  flank_angle: 20\n",
         "geometry.flank_angle = 20.0: the flank crosses the wall"),
        ("geometry:\n  mesh_file: meshes/nope.msh\n",
         "geometry.mesh_file = meshes/nope.msh: file not found"),
        ("geometry: 5\n", "geometry = 5: must be a mapping of keys"),
        ("- a\n- b\n", "top level must be a mapping"),
        ("time:\n  dt: [1\n", "YAML syntax error at line"),
    ],
)
def test_bad_input_one_line(tmp_path, text, expected):
    msg = _error(tmp_path, text)
    assert expected in msg


def test_missing_config_file(tmp_path):
    with pytest.raises(ConfigError, match=r"^config file .*nope\.yaml: not found$"):
        load_config(tmp_path / "nope.yaml")


def test_config_file_is_a_directory(tmp_path):
    with pytest.raises(ConfigError, match="is a directory"):
        load_config(tmp_path)


def test_empty_file_and_empty_section_mean_defaults(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("")
    assert load_config(path) == load_config(None)
    path.write_text("geometry:\n")
    assert load_config(path) == load_config(None)


@pytest.mark.parametrize("item", ["material.density", "density=3", "a.b.c=1", "=3", ".x=1"])
def test_malformed_set(item):
    with pytest.raises(ConfigError, match=r"^--set .*must be of the form section\.key=value$"):
        load_config(None, [item])


def test_overrides_change_values():
    cfg = load_config(RIGID, ["time.end_time=0.5", "numerics.ale=false",
                              "geometry.surface_mesh_size=0.005", "time.dt=1e-4",
                              "numerics.linear_solver=superlu_dist"])
    assert cfg.time.end_time == 0.5 and cfg.numerics.ale is False
    assert cfg.geometry.surface_mesh_size == 0.005 and cfg.time.dt == 1e-4
    assert cfg.numerics.linear_solver == "superlu_dist"
    assert load_config(None, ["geometry.surface_mesh_size=null"]).geometry.surface_mesh_size is None


@pytest.mark.parametrize(
    "item, expected",
    [
        ("material.density=-1", "material.density = -1: must be > 0 (kg/m^3)"),
        ("material.densty=1", "did you mean 'density'?"),
        ("tme.dt=1", "tme: unknown section; did you mean 'time'?"),
        ("time.dt=abc", "time.dt = 'abc': must be a number"),
        ("time.dt=[", "value is not valid YAML"),
    ],
)
def test_overrides_are_validated(item, expected):
    with pytest.raises(ConfigError) as info:
        load_config(RIGID, [item])
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_mesh_file_relative_to_config_folder(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    msh = tmp_path / "meshes" / "m.msh"
    msh.write_text("$MeshFormat\n")
    cfg_path = tmp_path / "sub" / "c.yaml"
    cfg_path.parent.mkdir()
    cfg_path.write_text("geometry:\n  mesh_file: ../meshes/m.msh\n")
    monkeypatch.chdir(ROOT)
    assert load_config(cfg_path).geometry.mesh_file == msh.resolve()


def test_save_load_round_trip(tmp_path):
    cfg = load_config(RIGID, ["time.end_time=0.3", "geometry.surface_mesh_size=0.004",
                              "numerics.ale=false"])
    out = save_config(cfg, tmp_path / "run" / "config.yaml")
    assert load_config(out) == cfg
    data = config_to_dict(cfg)
    assert yaml.safe_load(yaml.safe_dump(data)) == data
    assert data["output"]["directory"] == "runs/rigid"
    assert validate_config(data) == cfg


def test_round_trip_keeps_mesh_file(tmp_path):
    msh = tmp_path / "m.msh"
    msh.write_text("$MeshFormat\n")
    cfg = load_config(None, [f"geometry.mesh_file={msh}"])
    other = tmp_path / "elsewhere"
    assert load_config(save_config(cfg, other / "c.yaml")) == cfg


def test_with_overrides():
    cfg = load_config(RIGID)
    new = with_overrides(cfg, ["time.dt=2e-3"])
    assert new.time.dt == 2e-3 and cfg.time.dt == 1e-3
    with pytest.raises(ConfigError, match="time.dt = 0: must be > 0"):
        with_overrides(cfg, ["time.dt=0"])


def test_time_scheme_and_tolerance(tmp_path):
    """time.scheme bdf2 / time.tolerance: accepted together, refused with a one-line message
    naming the key otherwise."""
    cfg = load_config(None, ["time.scheme=bdf2", "time.tolerance=1e-3", "time.dt_max=0.02"])
    assert cfg.time.scheme == "bdf2" and cfg.time.tolerance == 1e-3
    assert load_config(None).time.scheme == "bdf1" and load_config(None).time.tolerance is None
    assert "time.tolerance" in _error(tmp_path, overrides=["time.tolerance=1e-3"])
    assert "time.tolerance" in _error(tmp_path, overrides=["time.scheme=bdf2", "time.tolerance=-1"])
    assert "time.adaptive" in _error(tmp_path, overrides=[
        "time.scheme=bdf2", "time.tolerance=1e-3", "time.adaptive=true"])
    assert "time.scheme" in _error(tmp_path, overrides=[
        "time.scheme=bdf2", "numerics.method=augmented_lagrangian"])
    assert "time.scheme" in _error(tmp_path, overrides=["time.scheme=bdf3"])
    assert "numerics.extrapolate" in _error(tmp_path, overrides=[
        "time.scheme=bdf2", "time.tolerance=1e-4", "time.dt_max=0.02", "numerics.extrapolate=true"])
    # the norm of the estimate: rms (default) or max; inert with fixed steps, so that
    # rigid.yaml (max) runs the fixed-step methods with time.tolerance=null alone
    cfg = load_config(None, ["time.scheme=bdf2", "time.tolerance=1e-3", "time.error_norm=max"])
    assert cfg.time.error_norm == "max" and load_config(None).time.error_norm == "rms"
    assert load_config(None, ["time.error_norm=max"]).time.tolerance is None
    assert "time.error_norm" in _error(tmp_path, overrides=[
        "time.scheme=bdf2", "time.tolerance=1e-3", "time.error_norm=l2"])


def test_material_is_a_union_on_the_law(caplog):
    """A key of the other law is refused, naming the law it belongs to (it used to be
    accepted and ignored); switching the law by an override keeps the shared keys and drops
    the old law's own (logged); a key set by an override is never dropped."""
    from dpcollapse.config import DruckerPragerMaterial, MuIMaterial

    with pytest.raises(ConfigError, match=r"^material.grain_diameter: unknown key; it belongs to "
                                          r"material.rheology = mu_i$"):
        load_config(RIGID, ["material.grain_diameter=1e-3"])
    with pytest.raises(ConfigError, match=r"^material.viscosity: unknown key; it belongs to "
                                          r"material.rheology = drucker_prager$"):
        load_config(RIGID, ["material.viscosity=2", "material.rheology=mu_i",
                            "material.friction_angle_2=40"])
    with caplog.at_level("INFO", logger="dpcollapse"):
        cfg = load_config(RIGID, ["material.friction_angle=20", "material.rheology=mu_i"])
    assert isinstance(cfg.material, MuIMaterial) and cfg.material.friction_angle == 20
    assert not hasattr(cfg.material, "viscosity")
    assert "material.viscosity not used by it, dropped" in caplog.text
    back = with_overrides(cfg, ["material.rheology=drucker_prager"])
    assert isinstance(back, Config) and isinstance(back.material, DruckerPragerMaterial)
    assert back.material.viscosity == 1.0 and back.material.density == cfg.material.density


def test_a_config_written_before_the_material_union_still_reads():
    """Run directories and sweeps of before 2026-12-04 wrote every law's keys: resume and
    the sweep's staleness check read them through ``from_saved``."""
    from dpcollapse.config import config_to_dict, from_saved, validate_config

    cfg = load_config(RIGID)
    old = config_to_dict(cfg)
    old["material"].update(friction_angle_2=31.0, inertial_number_I0=0.4, grain_diameter=7e-4,
                           grain_density=2500.0, viscosity_cap=None)
    with pytest.raises(ConfigError):
        validate_config(old)
    assert from_saved(old) == config_to_dict(cfg)
    assert from_saved(None) is None and from_saved({"time": {}}) == {"time": {}}


def test_a_two_phase_config_saved_before_a_default_changed_reads_with_the_old_value():
    """A two-phase run saved by a program older than model.cut_cell_pressure (or
    grain_pressure, yield_weighting) ran with the value the key was added with, not with
    today's default: resume and the sweep's staleness check must see that."""
    from dpcollapse.config import config_to_dict, from_saved, validate_config
    from dpcollapse.config.files import LEGACY_DEFAULTS

    cfg = load_config(ROOT / "configs" / "column_eulerian_a1.42.yaml")
    old = config_to_dict(cfg)
    for section, key in LEGACY_DEFAULTS:
        del old[section][key]
    read = config_to_dict(validate_config(from_saved(old)))
    for (section, key), value in LEGACY_DEFAULTS.items():
        assert read[section][key] == value != getattr(getattr(cfg, section), key)
    assert from_saved(config_to_dict(cfg)) == config_to_dict(cfg)   # written keys win
    rigid = config_to_dict(load_config(RIGID))                       # not two-phase: as is
    assert from_saved(rigid) == rigid


def test_the_mean_inertia_is_the_default_and_saved_runs_keep_theirs():
    """Issue 50 (docs/benchmarks/2026-12-07-two-phase-one-answer.md): a new two-phase config
    takes model.inertia mean; a run saved with energy (the default written into every config
    from 2026-12-05 to 2026-12-07) reads back with energy, one saved before the key with
    velocity (LEGACY_DEFAULTS)."""
    from dpcollapse.config import config_to_dict, from_saved, validate_config

    cfg = load_config(ROOT / "configs" / "column_eulerian_a1.42.yaml")
    assert cfg.model.inertia == "mean"
    saved = config_to_dict(cfg)
    saved["model"]["inertia"] = "energy"
    assert validate_config(from_saved(saved)).model.inertia == "energy"
    del saved["model"]["inertia"]
    assert validate_config(from_saved(saved)).model.inertia == "velocity"
