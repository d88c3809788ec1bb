"""The whole configuration (:class:`Config`) and its checks across sections."""

from __future__ import annotations

import math

from pydantic import (
    Field,
    PrivateAttr,
    model_validator,
)

from dpcollapse.config.fields import _fmt, _Section
from dpcollapse.config.geometry import GEOMETRIES, GeometryConfig, TrapezoidGeometry
from dpcollapse.config.material import DruckerPragerMaterial, MaterialConfig
from dpcollapse.config.models import ModelConfig, StokesModel
from dpcollapse.config.numerics import BoundaryConfig, NumericsConfig
from dpcollapse.config.run import InitialConfig, OutputConfig, TimeConfig
from dpcollapse.config.sizes import first_mesh, refuse_too_large
from dpcollapse.config.time_scheme import supports_bdf2
from dpcollapse.errors import ConfigError

#: numerics.nonlinear_atol = null: the fixed point's absolute stop as a fraction of the
#: error-controlled step's time.tolerance (measured on configs/rigid.yaml, 0.1 … 1 all meet
#: its accuracy rule, 0.3 is the fastest: docs/benchmarks/2026-12-04-nonlinear-atol.md) …
ATOL_FRACTION = 0.3
#: … but never above this fraction of time.rest_speed: an iterate accepted with an error near
#: the rest speed can hold a toe film just above it (measured: max norm at 3e-4, atol 9e-5
#: m/s, the 0.11 wheel's OpenBLAS: 4 of 5 kernels crept to 1.37–2 s; 3e-5 m/s: at rest at
#: 0.94 s, docs/benchmarks/2026-12-04-rigid-max-norm.md) …
REST_FRACTION = 0.03
#: … and with a fixed step, 1e-7 m/s.
FIXED_STEP_ATOL = 1.0e-7


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
    #: the time scheme a method chosen on the command line brought (``config.time_scheme``)
    _time_scheme_chosen: dict | None = PrivateAttr(default=None)

    @property
    def time_scheme_chosen(self) -> dict | None:
        """The time keys replaced for the method (run.json's ``time_scheme_chosen``), or None."""
        return self._time_scheme_chosen

    def set_time_scheme_chosen(self, chosen: dict) -> None:
        self._time_scheme_chosen = chosen

    @property
    def fixed_point_atol(self) -> float:
        """The absolute part of the fixed point's stop ‖δu‖ ≤ rtol ‖u‖ + atol [m/s]:
        ``numerics.nonlinear_atol``, or, when it is null, min(ATOL_FRACTION × ``time.tolerance``,
        REST_FRACTION × ``time.rest_speed``) with the error-controlled step (the nonlinear solve
        is asked for a fraction of the error the step itself may make, as implicit integrators
        with error control do — SUNDIALS/CVODE: 0.1 —, and for velocities well below the rest
        rule's) and FIXED_STEP_ATOL with a fixed step."""
        if self.numerics.nonlinear_atol is not None:
            return self.numerics.nonlinear_atol
        if self.time.tolerance is not None:
            return min(ATOL_FRACTION * self.time.tolerance, REST_FRACTION * self.time.rest_speed)
        return FIXED_STEP_ATOL

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
        if g.coordinates == "axisymmetric":
            self._axisymmetric()
        if g.periodic and self.numerics.ale:
            raise ConfigError(f"numerics.ale = true: a periodic domain is fixed; must be false "
                              f"with geometry.shape = {g.shape}")
        self._mesh_tolerance()
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
        if self.time.scheme == "bdf2" and not supports_bdf2(self.model.name, self.numerics.method):
            raise ConfigError(f"time.scheme = 'bdf2': only with model.name = stokes and "
                              f"numerics.method = regularized (got {self.model.name}, "
                              f"{self.numerics.method}); use bdf1")
        if self.numerics.remesh_film_trim_grains > 0 and self.material.rheology != "mu_i":
            raise ConfigError(f"numerics.remesh_film_trim_grains = "
                              f"{_fmt(self.numerics.remesh_film_trim_grains)}: needs "
                              f"material.rheology = mu_i (a grain diameter); use "
                              f"numerics.remesh_film_trim (a fraction of geometry.mesh_size)")
        if g.periodic and self.numerics.linear_solver == "iterative":
            raise ConfigError(f"numerics.linear_solver = 'iterative': not available on a periodic "
                              f"domain (geometry.shape = {g.shape}); use mumps or superlu_dist")
        return self

    @property
    def size_control(self) -> tuple[float, float, float] | None:
        """``numerics.mesh_tolerance`` [m/s] and the smallest and largest cell sizes [m] it
        may ask for (null bounds: geometry.mesh_size / 4 and × 4), or None."""
        n = self.numerics
        if n.mesh_tolerance is None:
            return None
        h = self.geometry.mesh_size
        return (n.mesh_tolerance, n.mesh_size_min if n.mesh_size_min is not None else h / 4,
                n.mesh_size_max if n.mesh_size_max is not None else 4 * h)

    def _mesh_tolerance(self) -> None:
        """The indicator-driven size (``numerics.mesh_tolerance``): the moving mesh of the 2D
        model only, and a size range that is one."""
        n = self.numerics
        if n.mesh_tolerance is None:
            for key in ("mesh_size_min", "mesh_size_max"):
                if getattr(n, key) is not None:
                    raise ConfigError(f"numerics.{key} = {_fmt(getattr(n, key))}: only with "
                                      "numerics.mesh_tolerance set (the indicator's size range)")
            return
        if self.model.name != "stokes" or not n.ale:
            raise ConfigError(f"numerics.mesh_tolerance = {_fmt(n.mesh_tolerance)}: only with "
                              "model.name = stokes and numerics.ale = true (the moving mesh's "
                              "remesher); must be null here")
        _, lo, hi = self.size_control
        if lo > hi:
            raise ConfigError(f"numerics.mesh_size_min = {_fmt(lo)} m: must be <= "
                              f"numerics.mesh_size_max ({_fmt(hi)} m)")
        if not lo <= self.geometry.mesh_size <= hi:
            raise ConfigError(f"geometry.mesh_size = {_fmt(self.geometry.mesh_size)} m: with "
                              f"numerics.mesh_tolerance it must lie in numerics.mesh_size_min"
                              f"..mesh_size_max ({_fmt(lo)}..{_fmt(hi)} m)")

    def _moving_mesh(self) -> None:
        """The mass's mesh must fit the cell limit and the machine (``geometry.mesh_size`` =
        1e-5 m asked gmsh for about 7e8 triangles): ``config.sizes``."""
        refuse_too_large(first_mesh(self))

    def _axisymmetric(self) -> None:
        """What the axisymmetric coordinates (``geometry.symmetry``) support today: the moving
        mesh's regularized flow (Picard or Newton) of a body of revolution on a flat bed, the
        axis x = 0 a frictionless symmetry side; the two-phase model on its uniform mesh (the
        adaptive box's remap conserves ∫ c dA, not ∫ 2πr c dA)."""
        first = "geometry.symmetry = 'axisymmetric'"
        if self.model.name not in ("stokes", "two_phase"):
            raise ConfigError(f"{first}: only with model.name = stokes or two_phase (got "
                              f"{self.model.name}); use geometry.symmetry = planar")
        m = self.model
        if m.name == "two_phase" and m.min_cell is not None:
            raise ConfigError(f"model.min_cell = {_fmt(m.min_cell)}: must be null with {first} "
                              f"(the adaptive box's remap conserves the area, not the volume)")
        if self.numerics.method != "regularized":
            raise ConfigError(f"{first}: only with numerics.method = regularized (got "
                              f"{self.numerics.method}: its multipliers have no hoop component)")
        if self.geometry.bed_angle != 0:
            raise ConfigError(f"geometry.bed_angle = {_fmt(self.geometry.bed_angle)}: must be 0 "
                              f"with {first} (an inclined bed breaks the symmetry)")
        b = self.boundary
        if b.channel_width is not None:
            raise ConfigError(f"boundary.channel_width = {_fmt(b.channel_width)}: side-wall "
                              f"friction has no meaning with {first}; must be null")
        if b.surface_tension > 0:
            raise ConfigError(f"boundary.surface_tension = {_fmt(b.surface_tension)}: must be 0 "
                              f"with {first} (the curvature has no azimuthal part)")
        if self.numerics.linear_solver == "iterative":
            raise ConfigError(f"numerics.linear_solver = 'iterative': not available with {first}; "
                              f"use mumps or superlu_dist")

    def _two_phase(self) -> None:
        """The fixed box must contain the column; the rest is refused (one line each)."""
        g, m = self.geometry, self.model
        self._layer_cell()
        if self.output.format != "xdmf":
            raise ConfigError(f"output.format = {self.output.format!r}: must be 'xdmf' with "
                              "model.name = two_phase")
        if getattr(g, "own_vessel", False):
            if m.min_cell is not None or m.max_cell is not None:
                key = "min_cell" if m.min_cell is not None else "max_cell"
                raise ConfigError(f"model.{key} = {_fmt(getattr(m, key))}: the adaptive box is for "
                                  f"the box scenes; must be null with geometry.shape = {g.shape}")
            self._unused_numerics("two_phase", allowed=("regularized", "picard"))
            refuse_too_large(first_mesh(self))
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
        refuse_too_large(first_mesh(self))
        self._unused_numerics("two_phase", allowed=("regularized", "picard"))

    def _layer_cell(self) -> None:
        """``model.layer_cell``: the adaptive box's second level, finer than ``min_cell`` by at
        most 16 (the thin layers' cells; ``domain.adaptive_box``)."""
        m = self.model
        if m.layer_cell is None:
            return
        if m.min_cell is None or m.min_cell >= (m.max_cell or self.geometry.mesh_size):
            raise ConfigError(f"model.layer_cell = {_fmt(m.layer_cell)}: needs the adaptive box "
                              "(model.min_cell below model.max_cell); must be null without it")
        if not m.min_cell / 16 <= m.layer_cell < m.min_cell:
            raise ConfigError(f"model.layer_cell = {_fmt(m.layer_cell)}: must be in "
                              f"[{m.min_cell / 16:g}, {m.min_cell:g}) m (model.min_cell/16 to below "
                              "model.min_cell; null: off)")

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
