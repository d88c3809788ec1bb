"""The silo scene (issue 28): its vessel, its sides and the refusal of bad geometry (one line
naming the key and the range, exit 2 from the CLI)."""

import math
import subprocess
import sys

import numpy as np
import pytest

from dpcollapse.config import load_config
from dpcollapse.errors import ConfigError
from dpcollapse.geometry.mesher import ORIFICE
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.scenes.registry import scene
from tests.helpers import ROOT

SILO = ROOT / "configs" / "silo.yaml"


@pytest.mark.parametrize("override, expected", [
    ("geometry.orifice_width=0.3", "geometry.orifice_width = 0.3: must be < geometry.width = 0.2 m"),
    ("geometry.fill_height=0.3", "geometry.fill_height = 0.3: must be <= geometry.bin_height = 0.22 m"),
    ("geometry.hopper_angle=95", "geometry.hopper_angle = 95: must be in (0, 90) degrees"),
    ("geometry.hopper_angle=10", "geometry.hopper_angle = 10.0: must be in (21.1, 90) degrees"),
    ("model.min_cell=0.002", "model.min_cell = 0.002: the adaptive box is for the box scenes"),
])
def test_bad_silo_input_is_one_line(override, expected):
    with pytest.raises(ConfigError) as err:
        load_config(SILO, [override])
    assert expected in str(err.value) and "\n" not in str(err.value)


def test_cli_exits_2_naming_the_key():
    run = subprocess.run([sys.executable, "-m", "dpcollapse.cli", "check", str(SILO), "--set",
                          "geometry.orifice_width=0.25"], capture_output=True, text=True)
    assert run.returncode == 2
    assert "geometry.orifice_width = 0.25: must be < geometry.width" in run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.parametrize("hopper", [None, 30.0])
def test_vessel_sides_and_fill(hopper):
    """The half vessel: an outflow orifice under the open top, the fill region of the
    config's area, the hopper's slanted wall with its outward normal at β from the horizontal."""
    cfg = load_config(SILO, [] if hopper is None else [f"geometry.hopper_angle={hopper}"])
    vessel = scene(cfg).container()
    orifice = vessel.of_kind(BoundaryKind.OUTFLOW)
    assert [b.tag for b in orifice] == [ORIFICE] and orifice[0].reference == (0.0, 0.22)
    region = vessel.fraction_region[0]
    x, y = region[:, 0], region[:, 1]
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    assert area == pytest.approx(cfg.geometry.area, rel=1e-12)
    if hopper is not None:
        wall = next(b for b in vessel.boundaries if b.name == "hopper")
        assert wall.slanted and wall.normal[0] == pytest.approx(math.cos(math.radians(hopper)))


def test_orifice_cells_must_fit_the_orifice():
    with pytest.raises(ConfigError, match=r"^geometry.orifice_mesh_size = 0.02: must be < 0.015 m"):
        load_config(SILO, ["geometry.orifice_mesh_size=0.02"])
