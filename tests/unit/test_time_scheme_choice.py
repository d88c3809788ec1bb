"""A method chosen on the command line brings its time scheme (issue 48,
``config.time_scheme``): configs/rigid.yaml is written for BDF2 with error control; --set
numerics.method=augmented_lagrangian (or model.name) runs with bdf1 and fixed steps, unless
the user set the time keys explicitly."""

import pytest

from dpcollapse.config import load_config
from dpcollapse.errors import ConfigError
from tests.helpers import ROOT

RIGID = ROOT / "configs" / "rigid.yaml"


def test_the_augmented_lagrangian_brings_bdf1_and_fixed_steps(caplog):
    import logging

    with caplog.at_level(logging.INFO, logger="dpcollapse"):
        cfg = load_config(RIGID, ["numerics.method=augmented_lagrangian"])
    assert (cfg.time.scheme, cfg.time.tolerance) == ("bdf1", None)
    chosen = cfg.time_scheme_chosen
    assert chosen["replaced"] == {"time.scheme": "bdf2", "time.tolerance": 3e-4}
    assert (chosen["scheme"], chosen["tolerance"]) == ("bdf1", None)
    assert "numerics.method = 'augmented_lagrangian'" in chosen["reason"]
    lines = [r.getMessage() for r in caplog.records if "time scheme chosen" in r.getMessage()]
    assert len(lines) == 1 and "fixed steps of time.dt = 0.001 s" in lines[0]


def test_an_explicit_time_key_is_the_users_choice():
    """--set time.scheme=bdf2 (or a tolerance) with the augmented Lagrangian is refused in one
    line naming the key, as before; so is a file that names both."""
    for extra, key in (("time.scheme=bdf2", "time.scheme"), ("time.tolerance=1e-3", "time.tolerance")):
        with pytest.raises(ConfigError) as err:
            load_config(RIGID, ["numerics.method=augmented_lagrangian", extra])
        assert str(err.value).startswith(key) and "\n" not in str(err.value)
    # the tolerance's refusal names the method, not a bdf2 the method refuses
    assert "numerics.method = 'augmented_lagrangian'" in str(err.value)
    assert "bdf2" not in str(err.value).split(":")[-1]


def test_a_file_that_names_the_method_and_bdf2_is_refused(tmp_path):
    path = tmp_path / "al.yaml"
    path.write_text(RIGID.read_text().replace("method: regularized", "method: augmented_lagrangian"))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).startswith("time.scheme = 'bdf2'")


def test_nothing_is_chosen_for_a_method_that_has_bdf2():
    for over in ([], ["numerics.nonlinear_solver=newton"], ["numerics.method=regularized"]):
        cfg = load_config(RIGID, over)
        assert cfg.time_scheme_chosen is None and cfg.time.scheme == "bdf2", over


def test_another_model_brings_it_too():
    cfg = load_config(ROOT / "configs" / "column_eulerian_a0.5.yaml",
                      ["time.scheme=bdf1"])   # a two-phase file: nothing to choose
    assert cfg.time_scheme_chosen is None
    cfg = load_config(RIGID, ["model.name=two_phase"])
    assert cfg.time.scheme == "bdf1" and cfg.time_scheme_chosen["replaced"]["time.scheme"] == "bdf2"
