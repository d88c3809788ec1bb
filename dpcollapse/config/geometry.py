"""``geometry``: one section class per scene (dpcollapse/scenes/), told apart by ``shape``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    Discriminator,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)

from dpcollapse.config.fields import Number, PathStr, _f, _fmt, _Section
from dpcollapse.errors import ConfigError

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


def _symmetry() -> Any:
    return _f("planar", "", "Coordinates of the 2D model: planar (x, y, per unit depth), or "
              "axisymmetric (x = r >= 0, y = z: the body of revolution about the axis x = 0, "
              "measure 2 pi r; stokes model with the regularized method, or two_phase without "
              "the adaptive box; flat bed)")


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

    @property
    def coordinates(self) -> str:
        """``symmetry`` of a scene that declares it (the column), else planar."""
        return getattr(self, "symmetry", "planar")

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
    symmetry: Literal["planar", "axisymmetric"] = _symmetry()
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
        if self.symmetry == "axisymmetric":
            volume = math.pi * self.base_length**2 * self.height
            return (f"cylindrical column: height {self.height:g} m, radius {self.base_length:g} m, "
                    f"aspect ratio {self.aspect_ratio:.3g}, volume {volume:.4g} m^3")
        return (f"column: height {self.height:g} m, half-width {self.base_length:g} m, "
                f"aspect ratio {self.aspect_ratio:.3g}, area {self.area:.4f} m^2")

    @model_validator(mode="after")
    def _fits(self) -> ColumnGeometry:
        limit = min(self.height, self.base_length)
        self._cells_fit(limit, f"column (must be < {limit:.3g} m = min(height, base_length))")
        return self


class HeapGeometry(_Geometry):
    """Half of a symmetric triangular heap: the right triangle (0, 0), (L0, 0), (0, H0), its
    flank at β = atan(H0/L0) to the bed, against a frictionless symmetry wall at x = 0."""

    shape: Literal["heap"] = _f("heap", "", "Half of a symmetric triangular heap")
    height: Number = _f(0.1, "m", "Height H0 of the heap on its axis", gt=0)
    base_length: Number = _f(0.1, "m", "Half-width L0: from the axis to the toe", gt=0)
    bed_angle: Number = _bed_angle()
    mesh_size: Number = _mesh_size()
    surface_mesh_size: Number | None = _surface_mesh_size()
    mesh_file: PathStr | None = _mesh_file("heap")

    @property
    def area(self) -> float:
        """H0 L0 / 2 [m^2]."""
        return 0.5 * self.height * self.base_length

    @property
    def flank_angle(self) -> float:
        """β = atan(H0/L0) [deg]."""
        return math.degrees(math.atan2(self.height, self.base_length))

    def describe(self) -> str:
        return (f"heap: height {self.height:g} m, half-width {self.base_length:g} m, flank "
                f"{self.flank_angle:.3g} deg, area {self.area:.4f} m^2")

    @model_validator(mode="after")
    def _fits(self) -> HeapGeometry:
        limit = 0.5 * min(self.height, self.base_length)
        self._cells_fit(limit, f"heap (must be < {limit:.3g} m = min(height, base_length)/2)")
        return self


class DamBreakStepGeometry(_Geometry):
    """A dam break on a step: the column [0, L0] x [s, s + H0] on a plateau y = s that runs
    from the wall x = 0 to its edge x_e, where the bed drops by s to the lower bed y = 0
    (scenes/dambreak_step.py)."""

    shape: Literal["dambreak_step"] = _f("dambreak_step", "", "A column released on a plateau "
                                         "that ends in a step down")
    height: Number = _f(0.1, "m", "Height H0 of the column", gt=0)
    base_length: Number = _f(0.1, "m", "Length L0 of the column, from the wall", gt=0)
    plateau_length: Number = _f(0.12, "m", "Distance x_e from the wall to the step's edge "
                                "(>= base_length: the column stands on the plateau)", gt=0)
    step_height: Number = _f(0.05, "m", "Height s of the step down to the lower bed", gt=0)
    bed_angle: Number = _bed_angle()
    mesh_size: Number = _mesh_size()
    surface_mesh_size: Number | None = _surface_mesh_size()
    mesh_file: PathStr | None = _mesh_file("column")

    @property
    def area(self) -> float:
        """H0 * L0 [m^2]."""
        return self.height * self.base_length

    def describe(self) -> str:
        return (f"column: height {self.height:g} m, length {self.base_length:g} m on a plateau "
                f"to x = {self.plateau_length:g} m, step {self.step_height:g} m, area "
                f"{self.area:.4f} m^2")

    @model_validator(mode="after")
    def _fits(self) -> DamBreakStepGeometry:
        if self.base_length > self.plateau_length:
            raise ConfigError(f"geometry.base_length = {_fmt(self.base_length)}: must be <= "
                              f"geometry.plateau_length = {_fmt(self.plateau_length)} m (the "
                              "column stands on the plateau)")
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
            least = self.base_length + self.layer_thickness / math.tan(math.radians(self.layer_end_angle))
            raise ConfigError(
                f"geometry.layer_length = {_fmt(self.layer_length)}: must be > geometry."
                f"base_length + layer_thickness/tan(layer_end_angle) = {least:.4g}"
                " m (the layer's top reaches past the toe)")
        return self


#: The smallest feature of a scene's own vessel (the silo's orifice), as a fraction of its
#: largest side: gmsh's geometric tolerance (Geometry.Tolerance) is 1e-8 of the model's size.
SMALLEST_FEATURE = 1.0e-7


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
    symmetry: Literal["planar", "axisymmetric"] = _symmetry()
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

    @property
    def fill_volume(self) -> float:
        """Volume of the initial fill of the cylindrical silo or conical hopper (axisymmetric:
        x = r, the orifice's diameter D, the bin's W) [m^3]: pi R^2 (H - y_h) plus the frustum
        pi y_h (R^2 + R d + d^2)/3 (d = D/2, R = W/2), or the frustum up to H."""
        r, d, h, yh = 0.5 * self.width, 0.5 * self.orifice_width, self.fill_height, self.hopper_top
        if h >= yh:
            return math.pi * r**2 * (h - yh) + math.pi * yh * (r**2 + r * d + d**2) / 3.0
        x = d + h * math.tan(math.radians(self.hopper_angle))
        return math.pi * h * (x**2 + x * d + d**2) / 3.0

    def describe(self) -> str:
        if self.symmetry == "axisymmetric":
            kind = ("cylindrical silo" if self.hopper_angle is None
                    else f"conical hopper (half-angle {self.hopper_angle:g} deg)")
            return (f"{kind}: diameter {self.width:g} m, fill {self.fill_height:g} m, orifice "
                    f"diameter {self.orifice_width:g} m, vessel height {self.bin_height:g} m, "
                    f"fill volume {self.fill_volume:.4g} m^3")
        kind = ("flat-bottomed silo" if self.hopper_angle is None
                else f"hopper (half-angle {self.hopper_angle:g} deg)")
        return (f"{kind}: width {self.width:g} m, fill {self.fill_height:g} m, orifice "
                f"{self.orifice_width:g} m, vessel height {self.bin_height:g} m")

    @model_validator(mode="after")
    def _fits(self) -> SiloGeometry:
        if self.orifice_width >= self.width:
            raise ConfigError(f"geometry.orifice_width = {_fmt(self.orifice_width)}: must be < "
                              f"geometry.width = {_fmt(self.width)} m")
        extent = max(self.width, self.bin_height)
        if self.orifice_width < SMALLEST_FEATURE * extent:
            # 1e-300 m: a mesh with edges of length 0 (a division by zero in the step's limit)
            raise ConfigError(f"geometry.orifice_width = {_fmt(self.orifice_width)}: must be in "
                              f"[{SMALLEST_FEATURE * extent:.3g}, {_fmt(self.width)}) m (at least "
                              f"{SMALLEST_FEATURE:g} of the vessel's largest side, {extent:g} m: "
                              "a finer one is near gmsh's geometric tolerance, 1e-8 of the model's size)")
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
    | Annotated[SiloGeometry, Tag("silo")] | Annotated[HeapGeometry, Tag("heap")]
    | Annotated[DamBreakStepGeometry, Tag("dambreak_step")],
    Discriminator(_shape_of),
]
#: geometry.shape -> its config class
GEOMETRIES: dict[str, type[_Geometry]] = {"trapezoid": TrapezoidGeometry, "layer": LayerGeometry,
                                          "column": ColumnGeometry, "erodible": ErodibleGeometry,
                                          "silo": SiloGeometry, "heap": HeapGeometry,
                                          "dambreak_step": DamBreakStepGeometry}
