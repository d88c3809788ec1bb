"""``initial``, ``time`` and ``output``: the initial state, time stepping and what is written."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

from pydantic import (
    Field,
    model_validator,
)

from dpcollapse.config.fields import Count, Number, PathStr, _f, _fmt, _Section
from dpcollapse.errors import ConfigError


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
        None, "m/s", "Error-controlled step (time.scheme bdf2): the local error estimate per "
        "step, in the norm time.error_norm over the velocity dofs; null: fixed steps (or "
        "time.adaptive)", gt=0)
    error_norm: Literal["rms", "max"] = _f(
        "rms", "", "Norm of the local error estimate that time.tolerance bounds: rms (root mean "
        "square over the velocity dofs) or max (largest dof: the toe's error is not diluted by "
        "the bulk's); inert with fixed steps (time.tolerance null)")
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
        # time.error_norm without a tolerance is inert (as dt_max is): a config file that sets
        # it (configs/rigid.yaml) runs the fixed-step methods with --set time.tolerance=null
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
