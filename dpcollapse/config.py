"""The validated run configuration: a tree of frozen pydantic models built from YAML.

Defaults live only in the model fields below; units are SI, angles are in degrees.
Every failure, from a missing file to a value out of range, raises
:class:`dpcollapse.errors.ConfigError` with one line naming the key path, the value given
and what is allowed, e.g. ``material.density = -3.0: must be > 0 (kg/m^3)``.

Public API: :func:`load_config`, :func:`validate_config`, :func:`with_overrides`,
:func:`config_to_dict`, :func:`save_config` and the :class:`Config` model tree.
"""

from __future__ import annotations

import logging
import math
import os
from difflib import get_close_matches
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Sequence

import annotated_types as at
import yaml
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from dpcollapse.errors import ConfigError

__all__ = [
    "BoundaryConfig",
    "ColumnGeometry",
    "ErodibleGeometry",
    "Config",
    "GeometryConfig",
    "LayerGeometry",
    "MaterialConfig",
    "ModelConfig",
    "SavageHutterModel",
    "StokesModel",
    "TwoPhaseModel",
    "NumericsConfig",
    "OutputConfig",
    "TimeConfig",
    "TrapezoidGeometry",
    "config_to_dict",
    "load_config",
    "save_config",
    "validate_config",
    "with_overrides",
]


# ----------------------------------------------------------------------------- field types
def _as_number(v: Any) -> Any:
    """Accept int/float and numeric strings (YAML 1.1 reads ``1e-3`` as a string); no bools."""
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise PydanticCustomError("dp_number", "must be a number")
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            raise PydanticCustomError("dp_number", "must be a number") from None
    return v


def _as_integer(v: Any) -> Any:
    """Refuse bools, which pydantic would otherwise take as 0/1."""
    if isinstance(v, bool):
        raise PydanticCustomError("dp_integer", "must be an integer")
    return v


def _as_path(v: Any) -> Any:
    """Refuse empty strings and non-strings as paths."""
    if isinstance(v, Path):
        return v
    if not isinstance(v, str) or not v.strip():
        raise PydanticCustomError("dp_path", "must be a non-empty path")
    return v


Number = Annotated[float, BeforeValidator(_as_number)]
Count = Annotated[int, BeforeValidator(_as_integer)]
PathStr = Annotated[Path, BeforeValidator(_as_path)]


def _f(default: Any, unit: str, doc: str, **constraints: Any) -> Any:
    """A field with its SI unit kept in the schema (for error messages) and the description."""
    desc = f"{doc} [{unit}]" if unit else doc
    if "gt" in constraints or "ge" in constraints or "lt" in constraints or "le" in constraints:
        constraints.setdefault("allow_inf_nan", False)
    return Field(default, description=desc, json_schema_extra={"unit": unit}, **constraints)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# ----------------------------------------------------------------------------- sections
# geometry: one class per scene (dpcollapse/scenes/), told apart by ``shape``


def _bed_angle() -> Any:
    return _f(0.0, "deg", "Slope theta of the bed; gravity = g (sin θ, -cos θ) in slope coordinates",
              ge=0, lt=90)


def _mesh_size() -> Any:
    return _f(0.01, "m", "Cell size of the mesh (and of remeshing)", gt=0)


def _surface_mesh_size() -> Any:
    return _f(None, "m", "Cell size on the free surface (refinement); null means mesh_size", gt=0)


def _mesh_file(what: str) -> Any:
    return _f(None, "", f"Gmsh .msh file to use instead of meshing the {what} "
              "(relative paths resolve against the config file's folder)")


class _Geometry(_Section):
    """Checks shared by the geometry classes (each declares its own keys, in file order).

    Each scene's class says what the models need to know of it: ``models``, the models
    (``model.name``) that can run it; ``periodic``, whether the domain is periodic in x (a
    fixed domain); ``footprint``, the (length, height) [m] of the material at t = 0."""

    models: ClassVar[tuple[str, ...]] = ("stokes",)
    periodic: ClassVar[bool] = False

    @property
    def footprint(self) -> tuple[float, float]:
        """(length, height) [m] of the initial material from the wall: what a box must hold."""
        return self.base_length, self.height

    @field_validator("mesh_file", mode="after", check_fields=False)
    @classmethod
    def _mesh_file_exists(cls, v: Path | None, info: ValidationInfo) -> Path | None:
        if v is None:
            return None
        base = Path((info.context or {}).get("base_dir", Path.cwd()))
        path = (v if v.is_absolute() else base / v).resolve()
        if not path.is_file():
            raise ConfigError(f"geometry.mesh_file = {v}: file not found")
        return path

    def _cells_fit(self, limit: float, what: str) -> None:
        for key in ("mesh_size", "surface_mesh_size"):
            h = getattr(self, key)
            if h is not None and h >= limit:
                raise ConfigError(f"geometry.{key} = {_fmt(h)}: larger than the {what}")


class TrapezoidGeometry(_Geometry):
    """A trapezoid against a left wall on the bed inclined by ``bed_angle`` (collapse, seed
    000 case b)."""

    models: ClassVar[tuple[str, ...]] = ("stokes", "savage_hutter", "two_phase")

    shape: Literal["trapezoid"] = _f(
        "trapezoid", "", "Shape of the initial mass: trapezoid against a wall, layer periodic "
        "in x, or rectangular column against a symmetry wall")
    height: Number = _f(0.25, "m", "Initial height h0 of the mass", gt=0)
    base_length: Number = _f(0.297, "m", "Base length l0, from the wall to the toe", gt=0)
    flank_angle: Number = _f(
        70.0, "deg", "Angle alpha0 at which the right flank rises back over the mass", gt=0, le=90
    )
    bed_angle: Number = _bed_angle()
    mesh_size: Number = _mesh_size()
    surface_mesh_size: Number | None = _surface_mesh_size()
    mesh_file: PathStr | None = _mesh_file("trapezoid")

    @property
    def top_length(self) -> float:
        """Length of the flat top, wall to the flank's crest: l0 - h0/tan(alpha0) [m]."""
        return self.base_length - self.height / math.tan(math.radians(self.flank_angle))

    @property
    def area(self) -> float:
        """Area of the mass (l0 + top_length)/2 * h0 [m^2]."""
        return 0.5 * (self.base_length + self.top_length) * self.height

    def describe(self) -> str:
        return (f"mass: height {self.height:g} m, base {self.base_length:g} m, "
                f"top length {self.top_length:.4f} m, area {self.area:.4f} m^2")

    @model_validator(mode="after")
    def _fits(self) -> TrapezoidGeometry:
        top = self.top_length
        if top <= 0:
            least = math.degrees(math.atan2(self.height, self.base_length))
            raise ConfigError(
                f"geometry.flank_angle = {_fmt(self.flank_angle)}: the flank crosses the wall "
                f"(top length = {top:.3g} m); must be > {least:.3g} degrees for height "
                f"{_fmt(self.height)} m and base_length {_fmt(self.base_length)} m"
            )
        limit = min(self.height, top)
        self._cells_fit(limit, f"mass (must be < {limit:.3g} m = min(height, top length))")
        return self


class LayerGeometry(_Geometry):
    """A layer of thickness ``height`` on the inclined bed, periodic in x with period
    ``base_length`` (inclined plane, seed 000 case a)."""

    models: ClassVar[tuple[str, ...]] = ("stokes",)
    periodic: ClassVar[bool] = True

    shape: Literal["layer"] = _f("layer", "", "The periodic layer")
    height: Number = _f(0.25, "m", "Thickness h of the layer", gt=0)
    base_length: Number = _f(0.297, "m", "Period L of the layer", gt=0)
    flank_angle: Number = _f(
        70.0, "deg", "Not used by the layer (accepted so that configs written for both shapes "
        "load)", gt=0, le=90)
    bed_angle: Number = _bed_angle()
    mesh_size: Number = _mesh_size()
    surface_mesh_size: Number | None = _surface_mesh_size()
    mesh_file: PathStr | None = _mesh_file("layer")

    @property
    def area(self) -> float:
        """L * h [m^2]."""
        return self.base_length * self.height

    def describe(self) -> str:
        return f"layer: thickness {self.height:g} m, period {self.base_length:g} m"

    @model_validator(mode="after")
    def _fits(self) -> LayerGeometry:
        limit = min(self.height, self.base_length)
        self._cells_fit(limit, f"layer (must be < {limit:.3g} m = min(height, base_length))")
        return self


class ColumnGeometry(_Geometry):
    """A rectangular column of height H0 and half-width L0 against a frictionless symmetry
    wall at x = 0, on the bed of ``boundary.bed_condition``."""

    models: ClassVar[tuple[str, ...]] = ("stokes", "savage_hutter", "two_phase")

    shape: Literal["column"] = _f("column", "", "The rectangular column")
    height: Number = _f(0.14, "m", "Initial height H0 of the column", gt=0)
    base_length: Number = _f(0.14, "m", "Half-width L0: from the symmetry wall to the front", gt=0)
    bed_angle: Number = _bed_angle()
    mesh_size: Number = _mesh_size()
    surface_mesh_size: Number | None = _surface_mesh_size()
    mesh_file: PathStr | None = _mesh_file("column")

    @property
    def area(self) -> float:
        """H0 * L0 [m^2]."""
        return self.height * self.base_length

    @property
    def aspect_ratio(self) -> float:
        """a = H0/L0 [-]."""
        return self.height / self.base_length

    def describe(self) -> str:
        return (f"column: height {self.height:g} m, half-width {self.base_length:g} m, "
                f"aspect ratio {self.aspect_ratio:.3g}, area {self.area:.4f} m^2")

    @model_validator(mode="after")
    def _fits(self) -> ColumnGeometry:
        limit = min(self.height, self.base_length)
        self._cells_fit(limit, f"column (must be < {limit:.3g} m = min(height, base_length))")
        return self


class ErodibleGeometry(TrapezoidGeometry):
    """The trapezoid of ``trapezoid`` released on a layer of the same material (seed 000 case
    II, erodible bed): the layer [0, layer_length] x [0, layer_thickness] on the bed, the
    trapezoid on top of it (its base at y = layer_thickness); two material regions (cell
    tags) in one conforming mesh."""

    models: ClassVar[tuple[str, ...]] = ("stokes", "two_phase")

    shape: Literal["erodible"] = _f("erodible", "", "The trapezoid on an erodible layer")
    layer_thickness: Number = _f(0.005, "m", "Thickness h_e of the erodible layer", gt=0)
    layer_length: Number = _f(
        0.80, "m", "Length of the layer, from the wall to its free right end (seed 000's "
        "l0 = 80 cm of case II, our reading)", gt=0)
    layer_end_angle: Number = _f(
        25.5, "deg", "Slope of the layer's free right end, rising from x = layer_length on the "
        "bed (a cohesionless layer ends at its angle of repose: seed 000's friction angle)",
        gt=0, le=90)
    mesh_file: PathStr | None = _mesh_file("trapezoid and its layer")

    @property
    def layer_area(self) -> float:
        """(layer_length - h_e/(2 tan(layer_end_angle))) * h_e [m^2]."""
        he = self.layer_thickness
        return (self.layer_length - 0.5 * he / math.tan(math.radians(self.layer_end_angle))) * he

    @property
    def footprint(self) -> tuple[float, float]:
        """The layer's length and the mass on it [m]."""
        return self.layer_length, self.layer_thickness + self.height

    @property
    def area(self) -> float:
        """Mass (l0 + top_length)/2 * h0 plus the layer [m^2]."""
        return 0.5 * (self.base_length + self.top_length) * self.height + self.layer_area

    def describe(self) -> str:
        return (f"mass: height {self.height:g} m, base {self.base_length:g} m, top length "
                f"{self.top_length:.4f} m on a layer {self.layer_thickness:g} m thick, "
                f"{self.layer_length:g} m long; area {self.area:.4f} m^2")

    @model_validator(mode="after")
    def _layer_fits(self) -> ErodibleGeometry:
        if self.layer_length - self.layer_thickness / math.tan(math.radians(
                self.layer_end_angle)) <= self.base_length:
            raise ConfigError(
                f"geometry.layer_length = {_fmt(self.layer_length)}: must be > geometry."
                f"base_length + layer_thickness/tan(layer_end_angle) = "
                f"{self.base_length + self.layer_thickness / math.tan(math.radians(self.layer_end_angle)):.4g}"
                " m (the layer's top reaches past the toe)")
        return self


class SiloGeometry(_Geometry):
    """A silo (flat-bottomed bin) or a hopper (``hopper_angle``) of width W filled to H, an
    orifice of width D centred in its bottom (Beverloo's law; seed 004's hour glass); the
    half [0, W/2] is meshed with x = 0 the symmetry line (scenes/silo.py)."""

    models: ClassVar[tuple[str, ...]] = ("two_phase",)
    #: the vessel is the scene's own (not model.box_length x box_height)
    own_vessel: ClassVar[bool] = True
    #: gravity is vertical in a silo
    bed_angle: ClassVar[float] = 0.0

    shape: Literal["silo"] = _f("silo", "", "The silo or hopper with an orifice in its bottom")
    width: Number = _f(0.2, "m", "Width W of the bin", gt=0)
    fill_height: Number = _f(0.2, "m", "Height H of the initial fill above the orifice", gt=0)
    bin_height: Number = _f(0.25, "m", "Height of the vessel above the orifice (the open top)",
                            gt=0)
    orifice_width: Number = _f(0.03, "m", "Width D of the orifice, centred in the bottom", gt=0)
    hopper_angle: Number | None = _f(
        None, "deg", "Half-angle beta of the hopper walls from the vertical (null: flat bottom)",
        gt=0, lt=90)
    mesh_size: Number = _mesh_size()
    orifice_mesh_size: Number | None = _f(
        None, "m", "Cell size at the orifice's centre and edges (graded to mesh_size); null "
        "means mesh_size", gt=0)
    empty_fraction: Number = _f(
        0.01, "", "The run ends with status emptied when the bin holds less than this fraction "
        "of its initial material", gt=0, lt=1)

    @property
    def hopper_top(self) -> float:
        """y_h = (W - D)/(2 tan beta) [m] (0: flat bottom)."""
        if self.hopper_angle is None:
            return 0.0
        return 0.5 * (self.width - self.orifice_width) / math.tan(math.radians(self.hopper_angle))

    @property
    def footprint(self) -> tuple[float, float]:
        return 0.5 * self.width, self.fill_height

    @property
    def area(self) -> float:
        """Area of the initial fill in the half vessel [m^2]."""
        r, d, h, yh = 0.5 * self.width, 0.5 * self.orifice_width, self.fill_height, self.hopper_top
        if h >= yh:
            return r * h - 0.5 * (r - d) * yh
        x = d + h * math.tan(math.radians(self.hopper_angle))
        return 0.5 * (d + x) * h

    def describe(self) -> str:
        kind = ("flat-bottomed silo" if self.hopper_angle is None
                else f"hopper (half-angle {self.hopper_angle:g} deg)")
        return (f"{kind}: width {self.width:g} m, fill {self.fill_height:g} m, orifice "
                f"{self.orifice_width:g} m, vessel height {self.bin_height:g} m")

    @model_validator(mode="after")
    def _fits(self) -> SiloGeometry:
        if self.orifice_width >= self.width:
            raise ConfigError(f"geometry.orifice_width = {_fmt(self.orifice_width)}: must be < "
                              f"geometry.width = {_fmt(self.width)} m")
        if self.fill_height > self.bin_height:
            raise ConfigError(f"geometry.fill_height = {_fmt(self.fill_height)}: must be <= "
                              f"geometry.bin_height = {_fmt(self.bin_height)} m (the fill is "
                              "inside the vessel)")
        if self.hopper_angle is not None and self.hopper_top >= self.bin_height:
            least = math.degrees(math.atan(0.5 * (self.width - self.orifice_width) / self.bin_height))
            raise ConfigError(f"geometry.hopper_angle = {_fmt(self.hopper_angle)}: must be in "
                              f"({least:.3g}, 90) degrees (the hopper's walls must meet the "
                              f"side walls below geometry.bin_height = {_fmt(self.bin_height)} m)")
        key = "orifice_mesh_size" if self.orifice_mesh_size is not None else "mesh_size"
        h = getattr(self, key)
        if h >= 0.5 * self.orifice_width:
            raise ConfigError(f"geometry.{key} = {_fmt(h)}: must be < {0.5 * self.orifice_width:.3g} m "
                              "(half the orifice: at least two cells across the half orifice)")
        limit = 0.5 * min(0.5 * self.width, self.bin_height)
        if self.mesh_size >= limit:
            raise ConfigError(f"geometry.mesh_size = {_fmt(self.mesh_size)}: must be < {limit:.3g} m "
                              "(half of min(width/2, bin_height))")
        return self


def _shape_of(value: Any) -> str:
    """The geometry class of a mapping or model: its ``shape``, trapezoid when absent."""
    if isinstance(value, dict):
        return value.get("shape", "trapezoid")
    return value.shape if isinstance(value, _Geometry) else "trapezoid"


GeometryConfig = Annotated[
    Annotated[TrapezoidGeometry, Tag("trapezoid")] | Annotated[LayerGeometry, Tag("layer")]
    | Annotated[ColumnGeometry, Tag("column")] | Annotated[ErodibleGeometry, Tag("erodible")]
    | Annotated[SiloGeometry, Tag("silo")],
    Discriminator(_shape_of),
]
#: geometry.shape -> its config class
GEOMETRIES: dict[str, type[_Geometry]] = {"trapezoid": TrapezoidGeometry, "layer": LayerGeometry,
                                          "column": ColumnGeometry, "erodible": ErodibleGeometry,
                                          "silo": SiloGeometry}


class _Material(_Section):
    """Granular material: what every law has. One class per law (``rheology``, the tag)."""

    rheology: str
    density: Number = _f(1550.0, "kg/m^3", "Bulk density rho", gt=0)
    friction_angle: Number = _f(
        25.5, "deg", "Internal friction angle; mu_s = tan (0: drucker_prager without cohesion is a "
        "Newtonian fluid of viscosity eta)", ge=0, lt=90)
    gravity: Number = _f(9.81, "m/s^2", "Magnitude g of gravity", gt=0, le=1000)
    cohesion: Number = _f(0.0, "Pa", "Cohesion kappa0: yield stress kappa0 + mu_s p in shear", ge=0)

    @property
    def mu_s(self) -> float:
        """Internal friction coefficient tan(friction_angle) [-]."""
        return math.tan(math.radians(self.friction_angle))


class DruckerPragerMaterial(_Material):
    """Drucker–Prager: the yield stress κ(p) = √2 (κ0 + μ_s [p]_+) and a Newtonian part η."""

    rheology: Literal["drucker_prager"] = _f(
        "drucker_prager", "", "drucker_prager (constant viscosity) or mu_i (rate-dependent)")
    viscosity: Number = _f(1.0, "Pa s", "Newtonian viscosity eta", ge=0)

    @model_validator(mode="after")
    def _newtonian_limit(self) -> DruckerPragerMaterial:
        """friction_angle = cohesion = 0 is a Newtonian fluid: some stress must remain."""
        if self.friction_angle == 0 and self.cohesion == 0 and self.viscosity == 0:
            raise ConfigError("material.viscosity = 0: must be > 0 when material.friction_angle "
                              "and material.cohesion are 0 (a fluid without any stress)")
        return self


class MuIMaterial(_Material):
    """μ(I): μ = μ_s + (μ_2 − μ_s)/(I0/I + 1), I = d γ̇ / √(p/ρ_s) (seed 004)."""

    rheology: Literal["mu_i"] = _f(
        "mu_i", "", "drucker_prager (constant viscosity) or mu_i (rate-dependent)")
    friction_angle_2: Number = _f(
        31.0, "deg", "Friction angle at large I; mu_2 = tan (must exceed friction_angle)",
        gt=0, lt=90)
    inertial_number_I0: Number = _f(0.4, "", "I0 of mu(I) = mu_s + (mu_2 - mu_s)/(I0/I + 1)", gt=0)
    grain_diameter: Number = _f(7.0e-4, "m", "Grain diameter d", gt=0)
    grain_density: Number = _f(2500.0, "kg/m^3", "Grain density rho_s in I = d gamma_dot/sqrt(p/rho_s)", gt=0)
    viscosity_cap: Number | None = _f(
        None, "Pa s", "Cap eta_max on the effective viscosity (null: none)", gt=0)

    @property
    def mu_2(self) -> float:
        """mu_2 = tan(friction_angle_2) [-]."""
        return math.tan(math.radians(self.friction_angle_2))

    @model_validator(mode="after")
    def _mu_order(self) -> MuIMaterial:
        if self.friction_angle == 0:
            raise ConfigError(
                "material.friction_angle = 0: must be in (0, 90) degrees for mu_i "
                "(0 only with drucker_prager: a Newtonian fluid)")
        if self.friction_angle_2 <= self.friction_angle:
            raise ConfigError(
                f"material.friction_angle_2 = {_fmt(self.friction_angle_2)}: must be > "
                f"material.friction_angle = {_fmt(self.friction_angle)} degrees for mu_i")
        return self


def _rheology_of(value: Any) -> str:
    """The material class of a mapping or model: its ``rheology``, drucker_prager when absent."""
    if isinstance(value, dict):
        return value.get("rheology", "drucker_prager")
    return getattr(value, "rheology", "drucker_prager")


MaterialConfig = Annotated[
    Annotated[DruckerPragerMaterial, Tag("drucker_prager")] | Annotated[MuIMaterial, Tag("mu_i")],
    Discriminator(_rheology_of),
]
#: material.rheology -> its config class (the law itself: dpcollapse.rheology.choice.LAWS)
MATERIALS: dict[str, type[_Material]] = {"drucker_prager": DruckerPragerMaterial, "mu_i": MuIMaterial}


class BoundaryConfig(_Section):
    """The bed (Coulomb friction or no slip) and the left wall (Coulomb friction)."""

    bed_condition: Literal["coulomb", "no_slip"] = _f(
        "coulomb", "", "Bed: no penetration + Coulomb friction, or no slip (u = 0)")
    bed_friction_angle: Number = _f(25.5, "deg", "Bed friction angle; mu_b = tan", ge=0, lt=90)
    wall_friction_angle: Number = _f(
        10.2, "deg", "Left-wall friction angle; mu_l = tan", ge=0, lt=90
    )
    channel_width: Number | None = _f(
        None, "m", "Width w of the channel: adds the side-wall friction (2/w) mu_w p u/|u| "
        "(null: no side walls)", gt=0)
    side_wall_friction_angle: Number = _f(
        10.2, "deg", "Side-wall friction angle; mu_w = tan (used with channel_width)", ge=0, lt=90)
    surface_tension: Number = _f(
        0.0, "N/m", "Local surface tension of seed 000 on the free surface: the height gamma0_bar "
        "of gamma0_i = gamma0_bar (max{0, 1 - ((i - i_c)/delta)^2})^2 around the node i_c of "
        "largest curvature, traction sigma.N = -gamma0_i C_i N (0: off; it must vanish with the "
        "mesh size, gamma0_bar = o(h))", ge=0)
    surface_tension_extent: Number = _f(
        3.0, "nodes", "Extent delta of the local surface tension around i_c, in free-surface "
        "nodes (used when surface_tension > 0)", gt=0)

    @property
    def mu_side(self) -> float:
        """Side-wall friction coefficient mu_w = tan(side_wall_friction_angle) [-]."""
        return math.tan(math.radians(self.side_wall_friction_angle))

    @property
    def mu_bed(self) -> float:
        """Bed friction coefficient mu_b = tan(bed_friction_angle) [-]."""
        return math.tan(math.radians(self.bed_friction_angle))

    @property
    def mu_wall(self) -> float:
        """Wall friction coefficient mu_l = tan(wall_friction_angle) [-]."""
        return math.tan(math.radians(self.wall_friction_angle))


class NumericsConfig(_Section):
    """Regularization, the fixed-point iteration, the linear solver and the moving mesh."""

    method: Literal["regularized", "augmented_lagrangian"] = _f(
        "regularized", "", "Treatment of the yield stress and wall friction: regularization "
        "(Picard) or augmented Lagrangian (exact rigid zones)")
    augmentation: Number | None = _f(
        None, "Pa s", "Augmented Lagrangian: penalty r (null: 2*rho*sqrt(g)*h0^1.5)", gt=0)
    augmentation_friction: Number | None = _f(
        None, "Pa s/m", "Augmented Lagrangian: friction penalty r_f (null: 10*r/h0)", gt=0)
    augmented_max_iterations: Count = _f(
        5000, "", "Augmented Lagrangian: most iterations per time step (each is one "
        "back-substitution, no factorization)", ge=1)
    epsilon: Number = _f(1.0e-6, "1/s", "Regularization of |D|", gt=0)
    epsilon_friction: Number = _f(1.0e-6, "m/s", "Regularization of |u_T| in wall friction", gt=0)
    nonlinear_rtol: Number = _f(
        1.0e-3, "", "Fixed-point stop: ||du|| <= rtol*||u|| + atol (relative part)", gt=0, lt=1
    )
    nonlinear_atol: Number = _f(1.0e-7, "m/s", "Fixed-point stop, absolute part", ge=0)
    max_iterations: Count = _f(100, "", "Most fixed-point iterations per time step", ge=1)
    nonlinear_solver: Literal["picard", "newton"] = _f(
        "picard", "", "Regularized method: Picard fixed point (secant viscosity, Anderson) or "
        "Newton (PETSc SNES, exact Jacobian, LU; same stop test on the velocity updates)")
    newton_line_search: Literal["bt", "basic", "l2", "cp", "nleqerr"] = _f(
        "bt", "", "Newton: SNES line search (bt backtracking, basic = full steps)")
    newton_max_iterations: Count = _f(
        25, "", "Newton: most iterations per time step (per continuation stage)", ge=1)
    newton_picard_start: Count = _f(
        0, "", "Newton: Picard iterations before the first Newton iteration of a step", ge=0, le=100)
    newton_fallback: bool = Field(
        True, strict=True, description="Newton: a time step Newton fails is redone by the "
        "Picard fixed point (with Anderson) before the step is halved")
    newton_epsilon_start: Number | None = _f(
        None, "1/s", "Newton: epsilon-continuation within a step, from this down to "
        "numerics.epsilon by factors of 10 (null: none)", gt=0)
    newton_epsilon_friction_start: Number | None = _f(
        None, "m/s", "Newton: continuation of the wall-friction regularization within a step, "
        "from this down to numerics.epsilon_friction by factors of 10 (null: none)", gt=0)
    newton_stop: Literal["update", "residual"] = _f(
        "update", "", "Newton: stop test. update: the Picard test on the velocity updates "
        "(>= 2 Jacobians per step); residual: predicted error ||du_k||*||F_k||/||F_k-1|| "
        "<= rtol*||u|| + atol after a full step (can stop after one Jacobian)")
    reuse_factorization: bool = _f(
        False, "", "Factorize once per time step; later fixed-point iterates solve with GMRES "
        "preconditioned by that LU (experimental)")
    extrapolate: bool = Field(
        False, strict=True, description="Start each step's fixed point from the linear "
        "extrapolation of the last two steps instead of the last state")
    fixed_iterations: Count | None = _f(
        None, "", "Regularized Picard: accept each step after this many fixed-point iterates "
        "even when nonlinear_rtol is not met (earlier when it is); 1: the linearly implicit "
        "step, viscosity and convection at the step's start (as Basilisk's granular.h); null: iterate "
        "to nonlinear_rtol", ge=1)
    anderson_depth: Count = _f(
        5, "", "Anderson acceleration of the fixed point: history length m (0 = plain Picard)",
        ge=0, le=50)
    linear_solver: Literal["mumps", "superlu_dist", "iterative"] = _f(
        "mumps", "", "Flow solver: direct LU (mumps, superlu_dist) or iterative (FGMRES, Schur "
        "fieldsplit, AMG velocity block; regularized method, not on a periodic layer)")
    krylov_rtol: Number = _f(
        1.0e-10, "", "linear_solver iterative: relative residual of the FGMRES solve", gt=0, lt=1)
    krylov_max_iterations: Count = _f(
        500, "", "linear_solver iterative: most FGMRES iterations per solve (more: the step "
        "is retried with half the time step)", ge=1)
    quadrature_degree: Count | None = _f(
        None, "", "Quadrature degree of the nonlinear terms (secant viscosity, convection, "
        "friction); null: UFL's estimate (8 in cells, 17 on friction facets)", ge=1, le=20)
    mesh_velocity_penalty: Number = _f(
        1.0e3, "", "Penalty xi-hat on (w-u).n on the free surface (dimensionless, applied as xi-hat/h)", gt=0
    )
    remesh_min_angle: Number = _f(
        12.0, "deg", "Remesh when the smallest cell angle falls below this", gt=0, lt=60
    )
    remesh_film_trim: Number = _f(
        0.0, "", "Remeshing cuts off the front film thinner than this fraction of "
        "geometry.mesh_size (vertical cut where the mass is last that thick; 0: off)", ge=0, lt=1)
    remesh_conserve_area: bool = Field(
        False, strict=True, description="Remeshing puts back the area that untangling a fold, "
        "trimming the film and resampling changed, by moving the free surface along its normal")
    ale: bool = Field(True, strict=True, description="Move the mesh (false: fixed domain)")

    @model_validator(mode="after")
    def _iterative(self) -> NumericsConfig:
        if self.linear_solver == "iterative" and self.method != "regularized":
            raise ConfigError(f"numerics.linear_solver = 'iterative': only with numerics.method "
                              f"= regularized (not {self.method}); use mumps or superlu_dist")
        if self.nonlinear_solver == "newton" and self.method != "regularized":
            raise ConfigError(f"numerics.nonlinear_solver = 'newton': only with numerics.method "
                              f"= regularized (not {self.method})")
        if self.nonlinear_solver == "newton" and self.linear_solver == "iterative":
            raise ConfigError("numerics.nonlinear_solver = 'newton': needs a direct "
                              "numerics.linear_solver (mumps or superlu_dist), not iterative")
        if self.fixed_iterations is not None and (self.method != "regularized"
                                                  or self.nonlinear_solver != "picard"):
            raise ConfigError(f"numerics.fixed_iterations = {self.fixed_iterations}: only with "
                              f"numerics.method = regularized and nonlinear_solver = picard")
        if self.linear_solver == "iterative" and self.reuse_factorization:
            raise ConfigError("numerics.reuse_factorization = true: needs a direct "
                              "numerics.linear_solver (mumps or superlu_dist), not iterative")
        return self


# model: one class per model (dpcollapse/models/), told apart by ``name``


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
        0.1, "Pa s", "Viscosity of the light fluid (Basilisk's mug = 1e-4 in rho sqrt(g) L^1.5, "
        "5e-3 Pa s at L = 0.05 m, diverged in the light fluid: docs/benchmarks/"
        "2026-12-02-column-eulerian.md)", gt=0)
    courant: Number = _f(
        0.4, "", "Courant number of the sub-cycled explicit advection of c (outflow of a cell per "
        "sub-step over its content)", gt=0, le=0.5)
    compression: Number = _f(
        1.0, "", "Interface compression: flux C |u.n| c_donor (1 - c_receiver) towards the fuller "
        "cell (0: plain upwind)", ge=0, le=2)
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


class InitialConfig(_Section):
    """Initial velocity (the initial pressure comes from the first step's fixed point)."""

    velocity: Literal["rest", "half_poiseuille"] = _f(
        "rest", "", "rest, or u = (U_s (2y/h - y^2/h^2), 0) across the layer")
    surface_speed: Number = _f(1.0, "m/s", "U_s of the half-Poiseuille profile", ge=0)


class TimeConfig(_Section):
    """Time stepping, output cadence and the at-rest stopping rule."""

    dt: Number = _f(1.0e-3, "s", "Time step (adaptive: the first step)", gt=0)
    dt_min: Number = _f(1.0e-6, "s", "Smallest time step when halving on failure", gt=0)
    adaptive: bool = Field(
        False, strict=True, description="Adapt the step: x1.2 after a fixed point of <= 3 "
        "iterations, x0.7 after > 12, within dt_max, the Courant bound and the mesh-motion limit")
    cfl: Number = _f(
        1.0, "", "Courant bound of the adaptive step: dt <= cfl min_K h_K/max_K |u| "
        "(h_K shortest edge of cell K, |u| at its vertices)", gt=0, le=10)
    dt_max: Number = _f(1.5e-3, "s", "Largest time step (adaptive or tolerance)", gt=0)
    scheme: Literal["bdf1", "bdf2"] = _f(
        "bdf1", "", "Time scheme of the 2D regularized model: bdf1 (backward Euler, mesh moved "
        "by the previous step's velocity) or bdf2 (variable-step BDF2, mesh moved by the "
        "velocity extrapolated to the step's middle; first order on a new mesh)")
    tolerance: Number | None = _f(
        None, "m/s", "Error-controlled step (time.scheme bdf2): RMS over the velocity dofs of "
        "the local error estimate per step; null: fixed steps (or time.adaptive)", gt=0)
    end_time: Number = _f(2.0, "s", "Simulated time cap", gt=0)
    output_every: Count = _f(20, "", "Write XDMF output every N steps", ge=1)
    checkpoint_every: Count = _f(50, "", "Write a restart checkpoint every N steps", ge=1)
    rest_speed: Number = _f(1.0e-3, "m/s", "At rest when max |u| stays below this ...", gt=0)
    rest_energy_fraction: Number = _f(
        0.0, "", "Also at rest while the kinetic energy stays below this fraction of its peak "
        "(0: off; for a deposit whose max |u| is held up by a few nodes)", ge=0, lt=1)
    rest_duration: Number = _f(0.05, "s", "... for this long; then the run ends", ge=0)

    @property
    def max_steps(self) -> int:
        """Number of steps of size dt needed to reach end_time (the step cap) [-]."""
        return max(1, math.ceil(self.end_time / self.dt - 1e-9))

    @model_validator(mode="after")
    def _dt_order(self) -> TimeConfig:
        if self.dt_min > self.dt:
            raise ConfigError(
                f"time.dt_min = {_fmt(self.dt_min)}: must be <= time.dt = {_fmt(self.dt)} (s)"
            )
        if self.adaptive and self.dt_max < self.dt:
            raise ConfigError(
                f"time.dt_max = {_fmt(self.dt_max)}: must be >= time.dt = {_fmt(self.dt)} (s) "
                f"with time.adaptive = true")
        if self.tolerance is not None:
            if self.scheme != "bdf2":
                raise ConfigError(f"time.tolerance = {_fmt(self.tolerance)}: needs the error "
                                  "estimate of time.scheme = bdf2; set time.scheme: bdf2 or "
                                  "time.tolerance: null")
            if self.adaptive:
                raise ConfigError("time.adaptive = true: must be false with time.tolerance "
                                  "set (one step-size rule at a time)")
            if self.dt_max < self.dt:
                raise ConfigError(
                    f"time.dt_max = {_fmt(self.dt_max)}: must be >= time.dt = {_fmt(self.dt)} "
                    f"(s) with time.tolerance set")
        return self


class OutputConfig(_Section):
    """Where results go."""

    directory: PathStr = _f(
        Path("runs/rigid"), "", "Run directory, relative to the working directory (--out overrides)"
    )
    format: Literal["xdmf", "vtx", "both"] = _f(
        "xdmf", "", "Field output: XDMF (solution.xdmf, every DOLFINx), ADIOS2 VTX (vtx/*.bp, "
        "DOLFINx built with ADIOS2: Debian 13 and later), or both; dpcollapse plot reads XDMF"
    )


class Config(_Section):
    """The whole configuration; every section has defaults."""

    geometry: GeometryConfig = Field(default_factory=TrapezoidGeometry, description="Initial mass")
    material: MaterialConfig = Field(default_factory=DruckerPragerMaterial, description="Material")
    boundary: BoundaryConfig = Field(default_factory=BoundaryConfig, description="Friction")
    model: ModelConfig = Field(default_factory=StokesModel, description="Model")
    numerics: NumericsConfig = Field(default_factory=NumericsConfig, description="Solvers")
    initial: InitialConfig = Field(default_factory=InitialConfig, description="Initial state")
    time: TimeConfig = Field(default_factory=TimeConfig, description="Time stepping")
    output: OutputConfig = Field(default_factory=OutputConfig, description="Output")

    @model_validator(mode="after")
    def _scene(self) -> Config:
        g = self.geometry
        if self.model.name not in g.models:
            shapes = [name for name, cls in GEOMETRIES.items() if self.model.name in cls.models]
            raise ConfigError(f"geometry.shape = {g.shape!r}: not available with model.name = "
                              f"{self.model.name}; must be one of "
                              + ", ".join(repr(x) for x in shapes))
        if self.model.name == "savage_hutter":
            self._depth_averaged()
        if self.model.name == "two_phase":
            self._two_phase()
        if self.model.name == "stokes":
            self._moving_mesh()
        if g.periodic and self.numerics.ale:
            raise ConfigError(f"numerics.ale = true: a periodic domain is fixed; must be false "
                              f"with geometry.shape = {g.shape}")
        if self.numerics.extrapolate and self.time.adaptive:
            # measured (1 cm rigid case, dt_max 1.5 ms): a 1–1.5 mm/s creep accepted at one
            # iteration per step went on from t = 0.9 s to the 1.8 s cap instead of stopping
            raise ConfigError("numerics.extrapolate = true with time.adaptive = true: measured "
                              "to creep instead of coming to rest; must be false with time.adaptive = true")
        if self.numerics.extrapolate and self.time.tolerance is not None:
            # measured (1 cm rigid case, tol 1e-4): accepted at one iterate from the
            # extrapolated start, the fixed point's error (≈ rtol‖u‖, not O(Δt³)) entered the
            # local error estimate and the step fell to 7e-6 s by t = 0.23 s
            raise ConfigError("numerics.extrapolate = true with time.tolerance set: measured to "
                              "drive the step to ~1e-5 s (the fixed point's error enters the "
                              "error estimate); must be false with time.tolerance")
        if self.time.scheme == "bdf2" and (self.model.name != "stokes"
                                           or self.numerics.method != "regularized"):
            raise ConfigError(f"time.scheme = 'bdf2': only with model.name = stokes and "
                              f"numerics.method = regularized (got {self.model.name}, "
                              f"{self.numerics.method}); use bdf1")
        if g.periodic and self.numerics.linear_solver == "iterative":
            raise ConfigError(f"numerics.linear_solver = 'iterative': not available on a periodic "
                              f"domain (geometry.shape = {g.shape}); use mumps or superlu_dist")
        return self

    def _moving_mesh(self) -> None:
        """The mass's mesh must fit the cell limit (``geometry.mesh_size`` = 1e-5 m asked gmsh
        for about 7e8 triangles)."""
        g = self.geometry
        cells = mesh_cells(g.area, g.mesh_size)
        if cells > MAX_GRID_CELLS:
            smallest = math.sqrt(g.area / (math.sqrt(3.0) / 4.0 * MAX_GRID_CELLS))
            raise ConfigError(
                f"geometry.mesh_size = {_fmt(g.mesh_size)}: about {cells:.3g} cells for the "
                f"{g.area:.4g} m^2 of the mass (about {cells * MEMORY_PER_CELL / 1e9:.3g} GB), more "
                f"than {MAX_GRID_CELLS}; must be >= {smallest:.3g} m")

    def _two_phase(self) -> None:
        """The fixed box must contain the column; the rest is refused (one line each)."""
        g, m = self.geometry, self.model
        if self.output.format != "xdmf":
            raise ConfigError(f"output.format = {self.output.format!r}: must be 'xdmf' with "
                              "model.name = two_phase")
        if getattr(g, "own_vessel", False):
            if m.min_cell is not None or m.max_cell is not None:
                key = "min_cell" if m.min_cell is not None else "max_cell"
                raise ConfigError(f"model.{key} = {_fmt(getattr(m, key))}: the adaptive box is for "
                                  f"the box scenes; must be null with geometry.shape = {g.shape}")
            self._unused_numerics("two_phase", allowed=("regularized", "picard"))
            return
        (length, height), what = g.footprint, "initial material"
        if m.box_length < length:
            raise ConfigError(f"model.box_length = {_fmt(m.box_length)}: must be >= {length:g} m "
                              f"(the box must contain the {what})")
        if m.box_height < height:
            raise ConfigError(f"model.box_height = {_fmt(m.box_height)}: must be >= {height:g} m "
                              f"(the box must contain the {what})")
        if m.min_cell is not None and m.min_cell > (m.max_cell or g.mesh_size):
            raise ConfigError(f"model.min_cell = {_fmt(m.min_cell)}: must be <= model.max_cell "
                              f"= {(m.max_cell or g.mesh_size):g} m (null: geometry.mesh_size)")
        if m.box_length < 2 * g.mesh_size or m.box_height < 2 * g.mesh_size:
            raise ConfigError(f"geometry.mesh_size = {_fmt(g.mesh_size)}: must be at most half "
                              "of model.box_length and model.box_height with model.name = two_phase")
        cells = box_cells(m.box_length, m.box_height, g.mesh_size)
        if cells > MAX_GRID_CELLS:
            raise ConfigError(
                f"model.box_length = {_fmt(m.box_length)}, model.box_height = {_fmt(m.box_height)}: "
                f"about {cells:.3g} cells at geometry.mesh_size = {_fmt(g.mesh_size)} m (about "
                f"{cells * MEMORY_PER_CELL / 1e9:.3g} GB), more than {MAX_GRID_CELLS}; a smaller "
                "box or a larger mesh size")
        self._unused_numerics("two_phase", allowed=("regularized", "picard"))

    def _unused_numerics(self, model: str, allowed: tuple[str, ...] = ()) -> None:
        """Refuse numerics keys set to a non-default value that ``model`` does not read
        (``allowed``: the method and nonlinear solver values it does run)."""
        n, default = self.numerics, NumericsConfig()
        if model == "two_phase":
            for key in ("method", "nonlinear_solver"):
                if getattr(n, key) not in allowed:
                    raise ConfigError(f"numerics.{key} = {getattr(n, key)!r}: model.name = "
                                      f"two_phase runs the regularized Picard iteration only; "
                                      f"must be {getattr(default, key)!r}")
            return
        changed = sorted(k for k in n.model_fields_set if getattr(n, k) != getattr(default, k))
        if changed:
            raise ConfigError(f"numerics.{changed[0]} = {_fmt(getattr(n, changed[0]))}: not used by "
                              f"model.name = {model} (its keys are under model.*); remove "
                              + ("it" if len(changed) == 1 else
                                 f"it and numerics.{', numerics.'.join(changed[1:])}"))

    def _depth_averaged(self) -> None:
        """What the 1D model cannot represent is refused (one line each)."""
        if self.initial.velocity != "rest":
            raise ConfigError(f"initial.velocity = {self.initial.velocity!r}: must be 'rest' "
                              "with model.name = savage_hutter")
        if self.output.format != "xdmf":
            raise ConfigError(f"output.format = {self.output.format!r}: must be 'xdmf' with "
                              "model.name = savage_hutter")
        m = self.model
        x_max = m.x_max if m.x_max is not None else self.geometry.base_length + 20 * self.geometry.height
        b, phi = self.boundary, self.material.friction_angle
        if (m.earth_pressure == "savage_hutter" and m.basal_friction == "bed"
                and b.bed_friction_angle > phi):
            # auto and rheology give delta <= phi (auto takes the bed only below phi)
            raise ConfigError(f"boundary.bed_friction_angle = {_fmt(b.bed_friction_angle)}: must be "
                              f"<= material.friction_angle = {_fmt(phi)} (deg) with "
                              "model.earth_pressure = savage_hutter (K_act/pass is imaginary for "
                              "delta > phi)")
        self._unused_numerics("savage_hutter")
        if m.x_min > 0 or x_max < self.geometry.base_length:
            raise ConfigError(f"model.x_min = {_fmt(m.x_min)}, model.x_max = {_fmt(m.x_max)}: "
                              f"the 1D domain must contain the mass [0, {self.geometry.base_length:g}] m")

    @property
    def gravity_vector(self) -> tuple[float, float]:
        """Gravity in slope coordinates, g (sin θ, -cos θ) [m/s^2]."""
        theta = math.radians(self.geometry.bed_angle)
        g = self.material.gravity
        return (g * math.sin(theta), -g * math.cos(theta))


# ----------------------------------------------------------------------------- errors
_TYPE_TEXT = {
    "dp_number": "must be a number",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "dp_integer": "must be an integer",
    "int_type": "must be an integer",
    "int_parsing": "must be an integer",
    "int_from_float": "must be an integer",
    "bool_type": "must be true or false",
    "bool_parsing": "must be true or false",
    "dp_path": "must be a non-empty path",
    "path_type": "must be a path",
    "model_type": "must be a mapping of keys",
    "model_attributes_type": "must be a mapping of keys",
    "finite_number": "must be a finite number",
}
_RANGE_TYPES = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def _fmt(value: Any) -> str:
    """A value as the user would write it in YAML, one line, not too long."""
    if value is None:
        text = "null"
    elif isinstance(value, bool):
        text = "true" if value else "false"
    else:
        text = repr(value) if not isinstance(value, Path) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."


#: Keys that were renamed: (section, old key) -> the new "section.key". A config that uses
#: the old name is refused with a message naming the new one.
RENAMED: dict[tuple[str, str], str] = {}

#: Sections whose value is one of several classes told apart by a tag (the tag appears in
#: pydantic's error locations after the section name).
_UNIONS: dict[str, dict[str, type[BaseModel]]] = {"geometry": GEOMETRIES, "material": MATERIALS,
                                                  "model": MODELS}
#: the tag key of each union section
_UNION_TAGS = {"geometry": "shape", "material": "rheology", "model": "name"}


def _walk(loc: Sequence[str]) -> tuple[list[str], type[BaseModel] | None]:
    """(the key path without union tags, the model class of the last section on it)."""
    model: type[BaseModel] | None = Config
    clean: list[str] = []
    parts = list(loc)
    while parts:
        part = parts.pop(0)
        clean.append(part)
        if model is None:
            continue
        variants = _UNIONS.get(part) if model is Config else None
        if variants is not None:
            model = variants.get(parts.pop(0)) if parts and parts[0] in variants else None
            continue
        field = model.model_fields.get(part)
        ann = getattr(field, "annotation", None)
        model = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
    return clean, model


def _model_at(loc: Sequence[str]) -> type[BaseModel] | None:
    """The model class found by walking ``loc`` down from Config (None if not a section)."""
    return _walk(loc)[1]


def _allowed_range(model: type[BaseModel], key: str) -> str:
    """'must be in (0, 90] degrees' / 'must be > 0 (kg/m^3)' from the field's constraints."""
    field = model.model_fields[key]
    unit = (field.json_schema_extra or {}).get("unit", "")  # type: ignore[union-attr]
    lo = hi = None
    for m in field.metadata:
        if isinstance(m, (at.Gt, at.Ge)):
            lo = ("(" if isinstance(m, at.Gt) else "[", getattr(m, "gt", getattr(m, "ge", None)))
        if isinstance(m, (at.Lt, at.Le)):
            hi = (")" if isinstance(m, at.Lt) else "]", getattr(m, "lt", getattr(m, "le", None)))
    if lo and hi:
        unit = "degrees" if unit == "deg" else unit
        return f"must be in {lo[0]}{lo[1]:g}, {hi[1]:g}{hi[0]} {unit}".rstrip()
    op, bound = ((">" if lo[0] == "(" else ">=", lo[1]) if lo else
                 ("<" if hi[0] == ")" else "<=", hi[1]))  # type: ignore[index]
    unit = "degrees" if unit == "deg" else unit
    return f"must be {op} {bound:g}" + (f" ({unit})" if unit else "")


def _from_validation_error(exc: ValidationError) -> ConfigError:
    """The first pydantic error as one line: key path, value given, what is allowed."""
    err = exc.errors()[0]
    raw = [str(p) for p in err["loc"]]
    loc, _ = _walk(raw)
    key = ".".join(loc)
    kind = err["type"]
    if kind == "extra_forbidden":
        if tuple(loc) in RENAMED:
            return ConfigError(f"{key}: renamed; use {RENAMED[tuple(loc)]}")
        parent = _model_at(raw[:-1])
        names = list(parent.model_fields) if parent else []
        tag = _UNION_TAGS.get(loc[0])
        others = [name for name, cls in _UNIONS.get(loc[0], {}).items()
                  if len(loc) == 2 and loc[-1] in cls.model_fields and cls is not parent]
        if tag and others:
            return ConfigError(f"{key}: unknown key; it belongs to {loc[0]}.{tag} = "
                               f"{' or '.join(others)}")
        close = get_close_matches(loc[-1], names, n=1)
        hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(names)
        what = "unknown section" if len(loc) == 1 else "unknown key"
        return ConfigError(f"{key}: {what}; {hint}")
    if kind == "union_tag_invalid":
        ctx = err.get("ctx", {})
        return ConfigError(f"{key}.{_UNION_TAGS.get(key, 'shape')} = {_fmt(ctx.get('tag'))}: must be one of "
                           f"{ctx.get('expected_tags', '?')}")
    value = _fmt(err.get("input"))
    parent = _model_at(raw[:-1])
    if kind in _RANGE_TYPES and len(loc) == 2 and parent is not None:
        text = _allowed_range(parent, loc[-1])
    elif kind == "literal_error":
        text = "must be one of " + str(err.get("ctx", {}).get("expected", "?"))
    else:
        text = _TYPE_TEXT.get(kind, err["msg"])
    return ConfigError(f"{key} = {value}: {text}".replace("\n", " "))


# ----------------------------------------------------------------------------- loading
def validate_config(data: Any, base_dir: str | Path | None = None) -> Config:
    """Validate a nested mapping into a Config; ``base_dir`` resolves a relative mesh_file.

    Empty sections (``geometry:`` with nothing under it) count as all defaults.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"config top level = {_fmt(data)}: must be a mapping of sections")
    data = {k: ({} if v is None else v) for k, v in data.items()}
    context = {"base_dir": Path(base_dir) if base_dir is not None else Path.cwd()}
    try:
        return Config.model_validate(data, context=context)
    except ValidationError as exc:
        raise _from_validation_error(exc) from None


#: Union sections whose kind an override may switch (``--set material.rheology=mu_i`` on a
#: Drucker–Prager file, a sweep over the law): -> the function that reads the current kind.
_SWITCHABLE = {"material": _rheology_of}


def _switch_kind(data: dict[str, Any], section: str, kind: Any, overridden: set) -> None:
    """An override gives ``section`` another kind: keep the keys the new kind has, drop the
    old kind's own (e.g. material.viscosity of drucker_prager for mu_i; logged, not silent).
    A key set by an override is kept: the new kind then refuses it with one line."""
    new = _UNIONS[section].get(kind) if isinstance(kind, str) else None
    if new is None or kind == _SWITCHABLE[section](data[section]):
        return
    dropped = [k for k in data[section]
               if k not in new.model_fields and (section, k) not in overridden]
    for k in dropped:
        del data[section][k]
    if dropped:
        logging.getLogger("dpcollapse").info(
            "%s.%s = %s: %s not used by it, dropped", section, _UNION_TAGS[section], kind,
            ", ".join(f"{section}.{k}" for k in dropped))


def _apply_overrides(data: dict[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Set ``section.key=value`` items (value parsed as YAML) into a copy of ``data``; an
    item that switches a section's kind (``_SWITCHABLE``) drops the old kind's own keys."""
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    overridden: set[tuple[str, str]] = set()
    for item in overrides:
        path, sep, raw = item.partition("=")
        parts = path.strip().split(".")
        if not sep or len(parts) != 2 or not all(p.isidentifier() for p in parts):
            raise ConfigError(f"--set {item!r}: must be of the form section.key=value")
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise ConfigError(f"--set {item!r}: value is not valid YAML") from None
        section, key = parts
        if data.get(section) is None:
            data[section] = {}
        if not isinstance(data[section], dict):
            raise ConfigError(f"{section} = {_fmt(data[section])}: must be a mapping of keys")
        if section in _SWITCHABLE and key == _UNION_TAGS[section]:
            _switch_kind(data, section, value, overridden)
        data[section][key] = value
        overridden.add((section, key))
    return data


#: Largest config or sweep file read [bytes]: a config is a few kB; a larger file (a
#: 50 MB list) would take minutes to parse.
MAX_INPUT_BYTES = 1_000_000


def read_input_text(path: Path, what: str = "config file") -> str:
    """The text of a config or sweep file: a regular file (not a FIFO or a device such as
    /dev/zero, which would block or never end) of at most MAX_INPUT_BYTES, checked before
    reading; every failure is one line (ConfigError)."""
    import stat

    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ConfigError(f"{what} {path}: not found") from None
    except OSError as exc:
        raise ConfigError(f"{what} {path}: cannot be read ({exc.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise ConfigError(f"{what} {path}: is a directory, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(f"{what} {path}: not a regular file (a pipe or a device); "
                          "give a YAML file")
    if info.st_size > MAX_INPUT_BYTES:
        raise ConfigError(f"{what} {path}: {info.st_size} bytes, more than the "
                          f"{MAX_INPUT_BYTES} a {what.split()[0]} may have")
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_INPUT_BYTES + 1)   # the file may have grown since the stat
    except OSError as exc:
        raise ConfigError(f"{what} {path}: cannot be read ({exc.strerror})") from None
    if len(data) > MAX_INPUT_BYTES:
        raise ConfigError(f"{what} {path}: more than {MAX_INPUT_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{what} {path}: cannot be read (not UTF-8 text)") from None


def parse_input_yaml(text: str, path: Path, what: str = "config file") -> Any:
    """Parse a config or sweep file's YAML: a key twice in one mapping refused, every
    failure one line (ConfigError)."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise ConfigError(f"{what} {path}: YAML syntax error{where}: {problem}") from None
    except RecursionError:
        raise ConfigError(f"{what} {path}: nested too deeply") from None


def _read_yaml(path: Path) -> Any:
    """The parsed YAML document at ``path``; every failure is one line."""
    text = read_input_text(path)
    try:
        return parse_input_yaml(text, path)
    except ConfigError as exc:
        if str(exc).endswith("nested too deeply"):
            raise ConfigError(f"{exc} (a config has two levels: section and key)") from None
        raise


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice in one mapping (PyYAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice in one mapping", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def load_config(path: str | Path | None, overrides: Sequence[str] = ()) -> Config:
    """Read a YAML config (None: all defaults), apply ``--set section.key=value`` overrides,
    validate, and return the frozen Config. Raises ConfigError (one line) on any problem."""
    if path is None:
        data, base = None, Path.cwd()
    else:
        path = Path(path)
        data, base = _read_yaml(path), path.parent
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path}: top level must be a mapping of sections, "
                          f"got {type(data).__name__}")
    return validate_config(_apply_overrides(data, overrides), base_dir=base)


def with_overrides(cfg: Config, overrides: Sequence[str]) -> Config:
    """A new Config: ``cfg`` with ``section.key=value`` overrides applied and re-validated."""
    return validate_config(_apply_overrides(config_to_dict(cfg), overrides))


def from_saved(data: Any) -> Any:
    """A config this program wrote (config.yaml, run.json's "config"), perhaps by a version
    of before 2026-12-04, whose single material class wrote every law's keys: those of
    another law than its ``rheology`` are dropped (they had no effect). Other data as is."""
    material = data.get("material") if isinstance(data, dict) else None
    law = MATERIALS.get(_rheology_of(material)) if isinstance(material, dict) else None
    if law is None:
        return data
    return {**data, "material": {k: v for k, v in material.items() if k in law.model_fields}}


def config_to_dict(cfg: Config) -> dict[str, Any]:
    """Plain nested dict of the config (YAML- and JSON-able; paths as strings)."""
    return cfg.model_dump(mode="json")


def save_config(cfg: Config, path: str | Path) -> Path:
    """Write the resolved config as YAML (parents created); returns the path written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(config_to_dict(cfg), sort_keys=False, default_flow_style=False)
    path.write_text("# dpcollapse resolved configuration\n" + text, encoding="utf-8")
    return path
