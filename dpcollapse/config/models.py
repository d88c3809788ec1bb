"""``model``: one section class per model (dpcollapse/models/), told apart by ``name``, and
the size bounds of their meshes and grids."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import (
    Discriminator,
    Tag,
    model_validator,
)

from dpcollapse.config.fields import Count, Number, _f, _fmt, _Section
from dpcollapse.errors import ConfigError


class StokesModel(_Section):
    """The 2D model: incompressible flow of the material on the scene's mesh (its solver
    settings are the ``numerics`` section)."""

    name: Literal["stokes"] = _f(
        "stokes", "", "Model: stokes (2D flow, numerics section), savage_hutter (1D "
        "depth-averaged, this section; docs/savage_hutter.md) or two_phase (granular and light "
        "fluid on a fixed box; docs/model.md)")


#: Most cells of a grid or mesh (1D grid, two-phase box): about 1 GB of state at the
#: two-phase model's cost per cell (MEMORY_PER_CELL); larger is refused before any array exists.
MAX_GRID_CELLS = 1_000_000
#: Bytes per cell of the two-phase box mesh (P2/P1 flow, DG0 fraction, LU fill-in), an
#: estimate for the limit above and the number ``dpcollapse check`` prints.
MEMORY_PER_CELL = 1000
#: Largest coordinate of a domain end [m].
MAX_EXTENT = 1.0e5


class SavageHutterModel(_Section):
    """The depth-averaged Savage–Hutter model on a 1D grid along the bed (x down the slope
    geometry.bed_angle): the scene's polygon as initial thickness, the basal friction from
    the bed condition or the rheology (models/savage_hutter/setup.py, docs/savage_hutter.md)."""

    name: Literal["savage_hutter"] = _f("savage_hutter", "", "The depth-averaged model")
    basal_friction: Literal["auto", "bed", "rheology"] = _f(
        "auto", "", "Basal friction mu_b: bed = Coulomb tan(boundary.bed_friction_angle); rheology "
        "= the material's (drucker_prager: Coulomb mu_s; mu_i: mu(I) with the depth-averaged I); "
        "auto = bed if boundary.bed_condition = coulomb and the bed angle is below "
        "material.friction_angle, else rheology")
    earth_pressure: Literal["hydrostatic", "savage_hutter"] = _f(
        "hydrostatic", "", "Longitudinal stress K g cos(theta) h^2/2: hydrostatic (K = 1) or "
        "savage_hutter (K_act/pass = 2 sec^2(phi) (1 -/+ sqrt(1 - cos^2(phi) sec^2(delta))) - 1, "
        "phi = material.friction_angle, delta the basal friction angle; active where du/dx >= 0; "
        "docs/savage_hutter.md)")
    shape_factor: Number = _f(
        1.0, "", "Shape factor alpha of the momentum flux alpha h u^2: 1 (plug profile) or 1.25 "
        "(Bagnold profile)", ge=1, le=1.5)
    alpha_depth: Number = _f(
        1.0e-3, "m", "Below this thickness alpha tapers linearly to 1 (bounds the alpha > 1 front)",
        gt=0)
    order: Literal[1, 2] = _f(
        1, "", "1: first-order HLL, forward Euler; 2: MUSCL (MC limiter) and Heun")
    cfl: Number = _f(0.9, "", "CFL number: dt <= cfl dx/max|wave speed|", gt=0, le=1)
    h_dry: Number = _f(1.0e-10, "m", "Thinner cells carry no momentum (dry)", ge=0)
    front_threshold: Number = _f(
        1.0e-3, "m", "Thickness that defines the front (furthest x where h crosses it)", gt=0)
    n_cells: Count = _f(800, "", "Number of finite-volume cells on [x_min, x_max]", ge=2,
                        le=MAX_GRID_CELLS)
    x_min: Number = _f(0.0, "m", "Upslope end of the 1D domain (the wall of the scene is at x = 0)",
                       ge=-MAX_EXTENT, le=MAX_EXTENT)
    x_max: Number | None = _f(
        None, "m", "Downslope end of the 1D domain; null: base_length + 20 height",
        ge=-MAX_EXTENT, le=MAX_EXTENT)
    left: Literal["wall", "open"] = _f(
        "wall", "", "Upslope end: wall (reflective wall or symmetry plane) or open (outflow)")
    right: Literal["wall", "open"] = _f("open", "", "Downslope end: wall or open")

    @model_validator(mode="after")
    def _interval(self) -> SavageHutterModel:
        if self.x_max is not None and self.x_max <= self.x_min:
            raise ConfigError(f"model.x_max = {_fmt(self.x_max)}: must be > model.x_min = "
                              f"{_fmt(self.x_min)} (m)")
        return self


def box_cells(length: float, height: float, mesh_size: float) -> float:
    """Estimated triangles of a box meshed at ``mesh_size`` (two per square of side h)."""
    return 2.0 * length * height / mesh_size ** 2


def mesh_cells(area: float, mesh_size: float) -> float:
    """Estimated triangles of a region of ``area`` meshed by gmsh at ``mesh_size``: equilateral
    triangles of side h, area sqrt(3)/4 h^2 each."""
    return area / (math.sqrt(3.0) / 4.0 * mesh_size ** 2)


class TwoPhaseModel(_Section):
    """The granular phase and a passive light fluid on a fixed box mesh (seed 003's Gerris and
    Basilisk method): a volume fraction c advected by the flow, mixture density and viscosity,
    p = 0 at the surface without tracking it (models/two_phase/, docs/model.md)."""

    name: Literal["two_phase"] = _f("two_phase", "", "The Eulerian two-phase model")
    box_length: Number = _f(1.0, "m", "Length of the fixed box [0, box_length] (must contain the mass)",
                            gt=0)
    box_height: Number = _f(1.0, "m", "Height of the fixed box [0, box_height] (must contain the mass)",
                            gt=0)
    air_density: Number = _f(
        1.55, "kg/m^3", "Density of the light fluid (default 1e-3 of 1550 kg/m^3: Basilisk's RHOF)",
        gt=0)
    air_viscosity: Number = _f(
        0.1, "Pa s", "Viscosity of the light fluid (Basilisk's mug = 1e-4 in rho sqrt(g) L^1.5 is "
        "5e-3 Pa s at L = 0.05 m: it diverged before the skew-symmetric convection and converges "
        "since, docs/benchmarks/2026-12-04-light-fluid.md)", gt=0)
    viscosity_average: Literal["arithmetic", "harmonic"] = _f(
        "arithmetic", "", "Mixture viscosity S of the granular S_g and the light 2 air_viscosity "
        "in a cell of fraction c: arithmetic S = c S_g + (1 - c) 2 eta_a (Basilisk) or harmonic "
        "1/S = c/S_g + (1 - c)/(2 eta_a) (Gerris; measured to stall the fixed point on the column: "
        "docs/benchmarks/2026-12-04-light-fluid.md)")
    yield_weighting: Literal["volume", "sharp", "saturated", "grains"] = _f(
        "grains", "", "Yield stress of a cell of fraction c, kappa_mix = w(c) kappa(p): grains "
        "w = min(1, c/1e-6), the grains' own wherever there are grains (the default since 2026-12-04: holds "
        "a heap below the friction angle, deposits come to rest); volume w = c (the default "
        "before: reproduces earlier runs); sharp w = H(c - 1/2); saturated w = min(1, 2c) "
        "(issue 27: docs/benchmarks/2026-12-04-two-phase-yield-weighting.md)")
    grain_pressure: Literal["effective", "total"] = _f(
        "effective", "", "Pressure in the grains' yield stress kappa(p), in mu(I)'s I and in the "
        "bed friction: effective p - p_a (default since 2026-12-05), p_a = rho_a g (depth below "
        "the domain's highest point), the light fluid's hydrostatic pressure that grain contacts "
        "do not carry: deposits independent of air_density (within 0.84 % over 1-15 kg/m^3); or "
        "total p (the default before: +2.6 % deposit height at 15 kg/m^3, the light fluid's "
        "weight a cohesion) (docs/benchmarks/2026-12-04-grain-pressure.md)")
    cut_cell_pressure: Literal["pointwise", "centroid"] = _f(
        "centroid", "", "Where the yield stress and mu(I) of a cell the interface cuts "
        "(0 < c < 1) read model.grain_pressure: centroid (default since 2026-12-05: the P1 "
        "pressure's value at the cell's centroid, its cell average: the grains of a cut cell "
        "feel their depth instead of the p - p_a <= 0 of the light fluid above them inside the "
        "cell; holds a heap with grain_pressure effective) or pointwise (at every quadrature "
        "point; the default before). The walls' friction reads it at the wall "
        "(docs/benchmarks/2026-12-04-cut-cell-pressure.md)")
    inertia: Literal["velocity", "energy", "mean"] = _f(
        "mean", "", "Densities of the time derivative: energy (rho(c^n) u^{n+1} - "
        "sqrt(rho(c^n) rho(c^{n-1})) u^n)/dt (the default from 2026-12-05 to 2026-12-07; "
        "Guermond & Quartapelle: "
        "with the skew-symmetric convection the consistent rho Du/Dt) or velocity rho(c^n) "
        "(u^{n+1} - u^n)/dt (the default before: leaves a force (1/2)(d rho/dt) u that pushes "
        "the front, runouts growing with refinement; docs/benchmarks/2026-12-05-two-phase-inertia.md) "
        "or mean (default since 2026-12-07: rho(c^n) u^{n+1} - (rho(c^n) + rho(c^{n-1}))/2 u^n)/dt: "
        "the force (1/2)(d rho/dt) u "
        "linear in the step's change of rho, which energy's geometric mean is only for small "
        "ratios (a drag on the front growing with the step: the tall columns 10 % short; "
        "docs/benchmarks/2026-12-07-two-phase-columns-cause.md, 2026-12-07-two-phase-one-answer.md)")
    courant: Number = _f(
        0.4, "", "Courant number of the sub-cycled explicit advection of c (outflow of a cell per "
        "sub-step over its content)", gt=0, le=0.5)
    compression: Number = _f(
        1.0, "", "Interface compression: flux C |u.n| c_donor (1 - c_receiver) towards the fuller "
        "cell (0: plain upwind)", ge=0, le=2)
    compression_direction: Literal["facet", "normal", "layer_normal", "skip_layers"] = _f(
        "normal", "", "Where the interface compression acts: normal (the default since 2026-12-05: "
        "each facet's flux weighted by |n_i . n_f|, n_i the interface normal from the gradient "
        "of c averaged to the vertices: across the interface, as OpenFOAM's compression velocity "
        "along grad c) or facet (the default before: across every facet with a jump of c, also "
        "along a thin layer, whose leading cells it pulls back into the fuller ones behind: "
        "fronts 10-25 % short; docs/benchmarks/2026-12-05-two-phase-compression.md); layer_normal: "
        "as normal, but in a layer thinner than two cells the normal of its height function "
        "(-h', 1), across the layer, so a tongue on the bed is not pulled back along itself; "
        "skip_layers: no compression in such a layer (docs/benchmarks/2026-12-07-two-phase-thin-front.md)")
    compression_speed: Literal["facet", "full"] = _f(
        "facet", "", "The interface compression's speed on a facet: facet |u.n_f| (interFoam's "
        "|phi_f|/|S_f|: none across an interface the flow runs along) or full |u| (the compression "
        "velocity C |u| n_i: also across the top of a layer sheared along the bed; "
        "docs/benchmarks/2026-12-07-two-phase-thin-front.md)")
    interface_flux: Literal["compression", "geometric"] = _f(
        "compression", "", "How c crosses the interface: compression (upwind flux plus the "
        "algebraic compression of model.compression, compression_direction, compression_speed) "
        "or geometric (PLIC: in each mixed cell a straight interface normal to the gradient of c "
        "averaged to the vertices holding c|K|; through each facet the granular share of the "
        "swept strip of the donor cell, limited by flux-corrected transport to keep c in [0, 1]; "
        "the compression keys are then unused; docs/model.md, "
        "docs/benchmarks/2026-12-07-two-phase-geometric-flux.md)")
    interface_normal: Literal["gradient", "height_function"] = _f(
        "gradient", "", "interface_flux geometric: the interface normal of a mixed cell, gradient "
        "(-grad of c averaged to the vertices, Youngs) or height_function (as gradient, but in a "
        "layer thinner than thin_layer_cells the normal (-h', 1) of its height function h(x) = "
        "column integral of c: a tongue on the bed thinner than a cell stays a layer instead of "
        "breaking into blobs; docs/benchmarks/2026-12-07-two-phase-geometric-flux.md)")
    thin_layer_cells: Number = _f(
        2.0, "", "compression_direction layer_normal / skip_layers (and interface_normal "
        "height_function): a layer whose thickness (the column "
        "integral of c over a strip of the fine cell's width) is below this many fine cells is thin "
        "(2: the vertex average of c spans a cell on either side); also where layer_cell refines",
        gt=0, le=20)
    open_top: Literal["traction_free", "hydrostatic"] = _f(
        "hydrostatic", "", "The open top's traction: hydrostatic (the default since 2026-12-07: "
        "sigma n = -p_a n, p_a = rho_a f.(x - x_ref) the light fluid at rest, zero at the highest "
        "point; on a level box the same as traction_free) or traction_free (the default before: "
        "sigma n = 0; on a tilted box, geometry.bed_angle > 0, the top is then no isobar of the "
        "light fluid, which cannot rest and circulates over the deposit: the 12 deg shallow mass "
        "crept at 8.7 mm/s at 3 s; docs/benchmarks/2026-12-07-two-phase-thin-front.md)")
    fraction_threshold: Number = _f(
        0.5, "", "A cell with c above this counts as granular (mass front, max speed)", gt=0, lt=1)
    grad_div: Number = _f(
        10.0, "", "gamma of the grad-div term gamma S (div u)(div v) with S the local secant "
        "viscosity of the mixture (0: off; docs/benchmarks/2026-12-02-two-phase-rest.md)", ge=0, le=100)
    min_cell: Number | None = _f(
        None, "m", "Adaptive mesh: cell size in the granular phase and its band (null: the uniform "
        "structured box of geometry.mesh_size; equal to max_cell: the uniform box of this size)",
        gt=0)
    max_cell: Number | None = _f(
        None, "m", "Adaptive mesh: cell size in the light fluid far from the granular phase "
        "(null: geometry.mesh_size)", gt=0)
    layer_cell: Number | None = _f(
        None, "m", "Adaptive mesh: a second, finer level of cells of this size in the thin layers "
        "(a grain column thinner than thin_layer_cells min_cell, e.g. the tongue on the bed ahead "
        "of the deposit's body) and a band of refine_band of these cells around them (null: off; "
        "below min_cell, at least min_cell/16; docs/model.md, "
        "docs/benchmarks/2026-12-07-two-phase-tongue-resolution.md)", gt=0)
    refine_fraction: Number = _f(
        0.01, "", "Adaptive mesh: cells with c above this are refined (with their band)", gt=0, lt=1)
    refine_band: Number = _f(
        4.0, "", "Adaptive mesh: width of the fine band around the granular cells, in min_cell",
        ge=1, le=50)
    refine_grading: Number = _f(
        0.3, "", "Adaptive mesh: growth of the cell size per unit distance beyond the band",
        gt=0, le=2)
    remesh_every: Count = _f(
        0, "", "Adaptive mesh: rebuild every this many steps as well (0: only when a granular "
        "cell is coarser than 1.5 min_cell)", ge=0)
    adaptive_dt: bool = _f(
        False, "", "Limit the step by the flow's Courant number: dt <= step_courant h_K/|u_K| "
        "over the cells with c > step_fraction (with time.dt as the largest step)")
    step_courant: Number = _f(
        0.5, "", "Courant number of adaptive_dt (cells crossed per step)", gt=0, le=2)
    step_fraction: Number = _f(
        0.01, "", "adaptive_dt: only the cells with c above this limit the step (0.5: the "
        "granular cells, not the light fluid's jets; the advection of c sub-cycles anyway)",
        gt=0, lt=1)


def _name_of(value: Any) -> str:
    """The model class of a mapping or model: its ``name``, stokes when absent."""
    if isinstance(value, dict):
        return value.get("name", "stokes")
    return getattr(value, "name", "stokes")


ModelConfig = Annotated[
    Annotated[StokesModel, Tag("stokes")] | Annotated[SavageHutterModel, Tag("savage_hutter")]
    | Annotated[TwoPhaseModel, Tag("two_phase")],
    Discriminator(_name_of),
]
#: model.name -> its config class
MODELS: dict[str, type[_Section]] = {"stokes": StokesModel, "savage_hutter": SavageHutterModel,
                                     "two_phase": TwoPhaseModel}
