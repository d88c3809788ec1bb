"""The config → depth-averaged model mapping, in one place (``setup_from_config``).

What a config means for the 1D model (docs/savage_hutter.md, "From a config"):

* slope θ = ``geometry.bed_angle`` (gravity g (sin θ, −cos θ) in slope coordinates, so x runs
  down the slope and h is the thickness normal to the bed); g = ``material.gravity``;
* initial thickness: the exact cell averages of the scene's polygon (``initial``): the
  trapezoid (wall at x = 0, toe at base_length, flank at flank_angle) or the column
  [0, base_length] × [0, height]; the initial mass equals the polygon's area to round-off;
* basal friction μ_b (``model.basal_friction``):
  - ``bed``: Coulomb, μ_b = tan(boundary.bed_friction_angle);
  - ``rheology``: drucker_prager → Coulomb μ_b = μ_s = tan(material.friction_angle);
    mu_i → μ(Ī) with the material's μ_s, μ_2, I0 and grain diameter d;
  - ``auto``: ``bed`` when boundary.bed_condition = coulomb and the bed friction angle is
    below material.friction_angle (the layer slides on the bed), else ``rheology`` (a no-slip
    or rougher bed: the material shears just above it, at its own friction);
* earth pressure (``model.earth_pressure``): hydrostatic K = 1, or Savage & Hutter's K_act/pass
  with φ = material.friction_angle and δ the angle of the basal law: bed →
  boundary.bed_friction_angle, rheology → φ (the material shears at its own friction);
* side walls: boundary.channel_width w and μ_w = tan(boundary.side_wall_friction_angle) add
  μ_w h/w to μ_b (the depth average of the 2D side-wall term);
* the numerical keys of the ``model`` section (α, h_α, order, CFL, h_dry, front threshold,
  cells, domain ends and their kinds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse.models.savage_hutter.earth_pressure import EarthPressure
from dpcollapse.models.savage_hutter.friction import CoulombFriction, MuIFriction, SideWallFriction
from dpcollapse.models.savage_hutter.initial import polygon_area, polygon_cell_averages
from dpcollapse.models.savage_hutter.solver import Grid, SavageHutter
from dpcollapse.rheology.choice import law_from_material
from dpcollapse.rheology.drucker_prager import DruckerPrager
from dpcollapse.rheology.mu_i import MuI
from dpcollapse.scenes.registry import scene as make_scene

__all__ = ["SavageHutterSetup", "basal_friction", "domain_end", "earth_pressure",
           "setup_from_config"]

#: The downslope end of the domain when model.x_max is null: base_length + this × height [m].
DEFAULT_RUNOUT_HEIGHTS = 20.0


@dataclass(frozen=True)
class SavageHutterSetup:
    """Everything a depth-averaged run of a config needs."""

    model: SavageHutter
    grid: Grid
    h0: np.ndarray            # initial cell thickness [m] (N)
    vertices: np.ndarray      # the scene's polygon in slope coordinates [m]
    area: float               # its area [m²] (= Σ h0 Δx to round-off)
    friction: str             # "bed" or "rheology": where μ_b came from


def domain_end(cfg) -> float:
    """x_max [m]: model.x_max, or base_length + DEFAULT_RUNOUT_HEIGHTS × height."""
    g = cfg.geometry
    return cfg.model.x_max if cfg.model.x_max is not None else (
        g.base_length + DEFAULT_RUNOUT_HEIGHTS * g.height)


def basal_friction(cfg) -> tuple[CoulombFriction | MuIFriction, str]:
    """(μ_b law, "bed" or "rheology") of ``model.basal_friction`` (module docstring)."""
    choice, b, m = cfg.model.basal_friction, cfg.boundary, cfg.material
    if choice == "auto":
        slides = b.bed_condition == "coulomb" and b.bed_friction_angle < m.friction_angle
        choice = "bed" if slides else "rheology"
    if choice == "bed":
        return CoulombFriction(b.mu_bed), choice
    law = law_from_material(m)
    return _DEPTH_AVERAGED_FRICTION[type(law)](law, m.gravity), choice


#: The basal friction that each 2D law gives the depth-averaged model (a law without an
#: entry here has no depth-averaged form: a KeyError in ``basal_friction``, a test checks
#: every law of ``rheology.choice.LAWS`` has one).
_DEPTH_AVERAGED_FRICTION = {
    DruckerPrager: lambda law, g: CoulombFriction(law.friction_coefficient),
    MuI: lambda law, g: MuIFriction(mu_s=law.mu_s, mu_2=law.mu_2, i0=law.I0,
                                    grain_diameter=law.grain_diameter, g=g),
}


def earth_pressure(cfg, source: str) -> EarthPressure | None:
    """None (K = 1) for ``model.earth_pressure: hydrostatic``, else Savage & Hutter's K_act/pass
    of φ = material.friction_angle and δ = the basal law's angle (``source``: "bed" or
    "rheology", from ``basal_friction``)."""
    if cfg.model.earth_pressure == "hydrostatic":
        return None
    phi = cfg.material.friction_angle
    delta = cfg.boundary.bed_friction_angle if source == "bed" else phi
    return EarthPressure.savage_hutter(phi, delta)


def scene_polygon(cfg) -> np.ndarray:
    """The initial mass of the config's scene as a polygon (wall at x = 0) [m]: the scene's
    own (``scenes/``; the config admits only scenes whose ``models`` include savage_hutter)."""
    points, _ = make_scene(cfg).polygon()
    return np.asarray(points, dtype=float)


def setup_from_config(cfg) -> SavageHutterSetup:
    """The depth-averaged model, grid and initial thickness of a validated config whose
    ``model.name`` is savage_hutter."""
    s, b = cfg.model, cfg.boundary
    basal, source = basal_friction(cfg)
    side = (SideWallFriction(mu_w=b.mu_side, width=b.channel_width)
            if b.channel_width is not None else None)
    model = SavageHutter(basal=basal, slope_deg=cfg.geometry.bed_angle, side_wall=side,
                         shape_factor=s.shape_factor, g=cfg.material.gravity, left=s.left,
                         right=s.right, cfl=s.cfl, h_dry=s.h_dry,
                         front_threshold=s.front_threshold, order=s.order,
                         alpha_depth=s.alpha_depth, earth_pressure=earth_pressure(cfg, source))
    grid = Grid(x_min=s.x_min, x_max=domain_end(cfg), n_cells=s.n_cells)
    vertices = scene_polygon(cfg)
    h0 = np.maximum(polygon_cell_averages(vertices, grid), 0.0)
    return SavageHutterSetup(model=model, grid=grid, h0=h0, vertices=vertices,
                             area=polygon_area(vertices), friction=source)
