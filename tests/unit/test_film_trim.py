"""The front film cut at remeshes in grain diameters (``numerics.remesh_film_trim_grains``,
issue 49): the film thinner than max(remesh_film_trim ΔX, remesh_film_trim_grains d)."""

from __future__ import annotations

import numpy as np
import pytest

from dpcollapse.ale.remesh import repair_polygon
from dpcollapse.config import load_config
from dpcollapse.domain.base import film_trim_thickness
from dpcollapse.errors import ConfigError
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.polygon import BoundaryPolygon
from tests.helpers import ROOT

COLUMN = ROOT / "configs" / "column_a1.42.yaml"


def test_the_trim_is_the_larger_of_the_mesh_and_the_grain_rules():
    cfg = load_config(COLUMN, ["numerics.remesh_film_trim=0.2",
                               "numerics.remesh_film_trim_grains=1.0"])
    d, dx = cfg.material.grain_diameter, cfg.geometry.mesh_size
    assert film_trim_thickness(cfg) == pytest.approx(max(0.2 * dx, d))
    assert d > 0.2 * dx      # 2.18 mm against 1 mm: the grain rule decides here
    coarse = load_config(COLUMN, ["numerics.remesh_film_trim=0.5",
                                  "numerics.remesh_film_trim_grains=0.1"])
    assert film_trim_thickness(coarse) == pytest.approx(0.5 * dx)


def test_grains_need_a_grain_diameter():
    with pytest.raises(ConfigError) as err:
        load_config(None, ["numerics.remesh_film_trim_grains=1.0"])   # Drucker–Prager
    message = str(err.value)
    assert "numerics.remesh_film_trim_grains" in message and "mu_i" in message
    assert "\n" not in message


def _block_with_film(thickness: float) -> BoundaryPolygon:
    """A mass [0, 0.1] × [0, 0.05] (wall at x = 0) ending in a film [0.1, 0.15] × [0, t]."""
    pts = np.array([[0.0, 0.0], [0.1, 0.0], [0.15, 0.0], [0.15, thickness], [0.1, thickness],
                    [0.1, 0.05], [0.0, 0.05]])
    tags = np.array([BED, BED, SURFACE, SURFACE, SURFACE, SURFACE, WALL])
    return BoundaryPolygon(pts, tags)


@pytest.mark.parametrize("grains, kept", [(0.8, False), (1.2, True)])
def test_a_film_thinner_than_a_grain_is_cut(grains, kept):
    cfg = load_config(COLUMN, ["numerics.remesh_film_trim_grains=1.0"])
    d = cfg.material.grain_diameter
    repaired = repair_polygon(_block_with_film(grains * d), film_trim_thickness(cfg))
    assert repaired.points[:, 0].max() == pytest.approx(0.15 if kept else 0.1)
