"""Time loop of the depth-averaged model: state, adaptive Δt, boundaries, rest detection, outputs.

A run is ``simulate(model, grid, h_init, u_init, times)``:

* ``SavageHutter`` — the physics and numerical parameters (slope θ [deg], shape factor α,
  basal friction law, optional side walls, g, boundary kinds, CFL number, dry and front
  thresholds);
* ``Grid`` — N uniform cells on [x_min, x_max] (x along the slope, metres);
* the initial thickness h [m] (and optionally the depth-averaged velocity ū [m/s]) as arrays of
  cell values or callables of x;
* the output times [s].

Each step takes Δt = min(CFL Δx / max|s|, positivity bound) (``scheme.interface_terms``),
shortened to land on the next output time. The run ends at the last output time, or earlier
when the state is a fixed point of the scheme: every ū = 0 (then no mass crosses any face) and a
step leaves every ū = 0 — the driving impulse and the friction impulse both scale with Δt, so no
later step changes anything.
``Result.rest_time`` records when; the remaining outputs repeat the final state.

Outputs (``Result``): at every output time the profiles h(x), ū(x) and the scalars; after
every step a time series of the same scalars:

* front — the furthest-downslope x where the piecewise-linear interpolant of the cell values of h
  through the cell centres crosses ``front_threshold`` [m] (NaN if h ≤ threshold everywhere);
* wet_front — the downslope edge of the furthest cell with h > h_dry;
* max_height, mass = Σ h Δx [m²] (per unit width), outflow = mass that left through open
  boundaries, max_speed = max |ū|.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from dpcollapse.fronts import profile_front
from dpcollapse.models.savage_hutter.earth_pressure import EarthPressure
from dpcollapse.models.savage_hutter.friction import CoulombFriction, MuIFriction, SideWallFriction
from dpcollapse.models.savage_hutter.scheme import (
    BOUNDARY_KINDS,
    Physics,
    friction_step,
    interface_terms,
    transport,
    update,
    velocity,
)

__all__ = ["Grid", "Result", "SavageHutter", "SolverDiverged", "front_position", "simulate"]

Profile = np.ndarray | Sequence[float] | Callable[[np.ndarray], np.ndarray] | float


class SolverDiverged(RuntimeError):
    """A non-finite value appeared, or the step budget ran out before the last output time."""


@dataclass(frozen=True)
class Grid:
    """N uniform cells on [x_min, x_max] [m]."""

    x_min: float
    x_max: float
    n_cells: int

    def __post_init__(self):
        if not (self.x_max > self.x_min and self.n_cells >= 2):
            raise ValueError(f"need x_max > x_min and n_cells >= 2, got {self}")

    @property
    def dx(self) -> float:
        """Cell width Δx [m]."""
        return (self.x_max - self.x_min) / self.n_cells

    @property
    def centers(self) -> np.ndarray:
        """Cell centres [m]."""
        return self.x_min + (np.arange(self.n_cells) + 0.5) * self.dx

    @property
    def edges(self) -> np.ndarray:
        """Cell edges [m] (N + 1)."""
        return self.x_min + np.arange(self.n_cells + 1) * self.dx

    def cell_values(self, profile: Profile, n_sub: int = 8) -> np.ndarray:
        """Cell averages of a callable (mean over n_sub equal sub-cells' midpoints), or the given
        array / constant broadcast to N cells."""
        if callable(profile):
            sub = (np.arange(n_sub) + 0.5) / n_sub
            x = self.x_min + (np.arange(self.n_cells)[:, None] + sub[None, :]) * self.dx
            return np.asarray(profile(x), dtype=float).mean(axis=1)
        values = np.broadcast_to(np.asarray(profile, dtype=float), (self.n_cells,))
        return values.copy()


@dataclass(frozen=True)
class SavageHutter:
    """Parameters of the depth-averaged model (SI units; angles in degrees).

    slope_deg: bed inclination θ, x pointing down the slope; basal: ``CoulombFriction`` or
    ``MuIFriction``; side_wall: ``SideWallFriction`` or None; shape_factor: α (1 or 5/4);
    left/right: "wall" (reflective wall or symmetry plane) or "open" (zero-gradient outflow);
    cfl ≤ 1; h_dry [m]: thinner cells carry no momentum; front_threshold [m]: the thickness that
    defines ``front``; well_balanced: friction locks interfaces at rest (``scheme``; False only
    to demonstrate the creep of the plain split); order: 1 (first-order HLL, forward Euler) or 2
    (MUSCL reconstruction of h and ū with the MC limiter, Heun's two-stage Runge–Kutta);
    alpha_depth [m]: below this thickness the shape factor tapers linearly to 1 (``scheme``: the
    α > 1 front); earth_pressure: None (K = 1, hydrostatic) or an ``EarthPressure`` (Savage &
    Hutter's K_act/pass, ``earth_pressure``)."""

    basal: CoulombFriction | MuIFriction
    slope_deg: float = 0.0
    side_wall: SideWallFriction | None = None
    shape_factor: float = 1.0
    g: float = 9.81
    left: str = "wall"
    right: str = "open"
    cfl: float = 0.9
    h_dry: float = 1e-10
    front_threshold: float = 1e-3
    well_balanced: bool = True
    order: int = 1
    alpha_depth: float = 1e-3
    earth_pressure: EarthPressure | None = None

    def __post_init__(self):
        if self.left not in BOUNDARY_KINDS or self.right not in BOUNDARY_KINDS:
            raise ValueError(f"boundaries must be in {BOUNDARY_KINDS}, got {self.left}, "
                             f"{self.right}")
        if not 1.0 <= self.shape_factor <= 1.5:
            raise ValueError(f"shape_factor must be in [1, 1.5], got {self.shape_factor}")
        if self.order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {self.order}")
        if not (0 < self.cfl <= 1):
            raise ValueError(f"cfl must be in (0, 1], got {self.cfl}")
        if not (-90 < self.slope_deg < 90 and self.g > 0 and self.h_dry >= 0
                and self.front_threshold > 0 and self.alpha_depth > 0):
            raise ValueError("need |slope_deg| < 90, g > 0, h_dry >= 0, front_threshold > 0, "
                             "alpha_depth > 0")

    def physics(self) -> Physics:
        """The step's ``scheme.Physics``."""
        return Physics(g=self.g, theta=math.radians(self.slope_deg), alpha=self.shape_factor,
                       basal=self.basal, side_wall=self.side_wall, h_dry=self.h_dry,
                       well_balanced=self.well_balanced, alpha_depth=self.alpha_depth,
                       earth_pressure=self.earth_pressure)


@dataclass
class Result:
    """Outputs of ``simulate`` (per-output arrays have one row/entry per requested time)."""

    grid: Grid
    times: np.ndarray                 # requested output times [s]
    h: np.ndarray                     # (n_times, N) thickness [m]
    u: np.ndarray                     # (n_times, N) depth-averaged velocity [m/s]
    front: np.ndarray                 # [m] at output times (threshold front)
    wet_front: np.ndarray             # [m]
    max_height: np.ndarray            # [m]
    mass: np.ndarray                  # [m²] per unit width
    series: dict = field(default_factory=dict)  # per step: t, front, wet_front, max_height,
    #                                             mass, outflow, max_speed, dt
    steps: int = 0
    rest_time: float | None = None  # [s] when the state became a fixed point (None: never)
    cpu_seconds: float = 0.0           # time.process_time() spent in the loop
    initial_mass: float = 0.0


def front_position(h: np.ndarray, grid: Grid, threshold: float) -> float:
    """Largest x where the linear interpolant of (x_i, h_i) through the cell centres reaches
    threshold (NaN if none): ``fronts.profile_front``, every model's front."""
    return profile_front(grid.centers, h, threshold)


def wet_front_position(h: np.ndarray, grid: Grid, h_dry: float) -> float:
    """Downslope edge of the furthest cell with h > h_dry (NaN if none) [m]."""
    wet = np.flatnonzero(h > h_dry)
    return grid.x_min + (int(wet[-1]) + 1) * grid.dx if wet.size else math.nan


def _heun_step(h, q, terms, dt, phys, model, dx):
    """Heun (SSP-RK2) on transport and gravity, the implicit friction applied to each stage and,
    once over Δt, to the combination::

        U¹ = P(U + Δt T(U)),   h^{n+1} = (h + h¹ + Δt T_h(U¹))/2,
        q^{n+1} = P(q + Δt (T_q(U) + T_q(U¹))/2)

    (T the transport-plus-gravity tendency, P the friction step). Applying P to the average of
    two friction steps instead would halve a stopping momentum each step and never reach 0.
    Δt is cut to the second stage's hard bound (CFL 1 and positivity of h) when that is smaller.
    Returns (h, q, Δt, mass that left through the boundaries)."""
    for _ in range(20):
        h1, q1_star = transport(h, q, terms, dx, dt)
        q1 = friction_step(h1, q1_star, phys, dt)
        terms1 = interface_terms(h1, q1, phys, dx, model.cfl, model.left, model.right, 2)
        if terms1.dt_hard >= dt:
            break
        dt = terms1.dt_max
    h2, q2_star = transport(h1, q1, terms1, dx, dt)
    h_new = 0.5 * (h + h2)
    q_new_star = q + 0.5 * ((q1_star - q) + (q2_star - q1))
    q_new = friction_step(h_new, q_new_star, phys, dt)
    lost = 0.5 * dt * (float(terms.mass_flux[-1] - terms.mass_flux[0])
                       + float(terms1.mass_flux[-1] - terms1.mass_flux[0]))
    return h_new, q_new, dt, lost


def simulate(model: SavageHutter, grid: Grid, h_init: Profile, times: Sequence[float],
             u_init: Profile = 0.0, max_steps: int = 10_000_000,
             stop_at_rest: bool = True, record_series: bool = True) -> Result:
    """Run from t = 0 to max(times); see the module docstring for inputs and outputs."""
    times = np.asarray(sorted(float(t) for t in times))
    if times.size == 0 or times[0] < 0:
        raise ValueError("times must be a non-empty list of t >= 0")
    phys = model.physics()
    dx = grid.dx
    h = grid.cell_values(h_init)
    if np.any(h < 0) or not np.all(np.isfinite(h)):
        raise ValueError("initial thickness must be finite and >= 0")
    q = np.where(h > model.h_dry, h * grid.cell_values(u_init), 0.0)

    n_out = times.size
    out_h = np.empty((n_out, grid.n_cells))
    out_u = np.empty((n_out, grid.n_cells))
    series = {k: [] for k in ("t", "front", "wet_front", "max_height", "mass", "outflow",
                              "max_speed", "dt")}
    initial_mass = float(np.sum(h) * dx)
    outflow = 0.0

    def record(t, dt):
        u = velocity(h, q, model.h_dry)
        series["t"].append(t)
        series["front"].append(front_position(h, grid, model.front_threshold))
        series["wet_front"].append(wet_front_position(h, grid, model.h_dry))
        series["max_height"].append(float(np.max(h)))
        series["mass"].append(float(np.sum(h) * dx))
        series["outflow"].append(outflow)
        series["max_speed"].append(float(np.max(np.abs(u))))
        series["dt"].append(dt)

    t = 0.0
    k_out = 0
    steps = 0
    rest_time = None
    start = time.process_time()
    if record_series:
        record(t, 0.0)
    while k_out < n_out:
        while k_out < n_out and t >= times[k_out]:
            out_h[k_out] = h
            out_u[k_out] = velocity(h, q, model.h_dry)
            k_out += 1
        if k_out == n_out:
            break
        terms = interface_terms(h, q, phys, dx, model.cfl, model.left, model.right, model.order)
        at_rest_before = stop_at_rest and not q.any() and not terms.mass_flux.any()
        if steps >= max_steps:
            raise SolverDiverged(f"step budget {max_steps} exhausted at t = {t:g} s")
        dt = min(terms.dt_max, times[k_out] - t)
        if not (dt > 0 and math.isfinite(dt)):
            raise SolverDiverged(f"time step {dt!r} at t = {t:g} s")
        if model.order == 1:
            outflow += dt * (float(terms.mass_flux[-1]) - float(terms.mass_flux[0]))
            h, q = update(h, q, terms, phys, dx, dt)
        else:
            h, q, dt, lost = _heun_step(h, q, terms, dt, phys, model, dx)
            outflow += lost
        if at_rest_before and not q.any():
            rest_time = t
            out_h[k_out:] = h
            out_u[k_out:] = 0.0
            break
        t = times[k_out] if dt == times[k_out] - t else t + dt
        steps += 1
        if record_series:
            record(t, dt)
        if not np.isfinite(q[np.argmax(np.abs(q))]):
            raise SolverDiverged(f"non-finite momentum at t = {t:g} s")
    cpu = time.process_time() - start

    front = np.array([front_position(row, grid, model.front_threshold) for row in out_h])
    wet = np.array([wet_front_position(row, grid, model.h_dry) for row in out_h])
    return Result(grid=grid, times=times, h=out_h, u=out_u, front=front, wet_front=wet,
                  max_height=out_h.max(axis=1), mass=out_h.sum(axis=1) * dx,
                  series={k: np.asarray(v) for k, v in series.items()}, steps=steps,
                  rest_time=rest_time, cpu_seconds=cpu, initial_mass=initial_mass)
