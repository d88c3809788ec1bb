"""The depth-averaged model in the time loop (``simulation``): the loop's Model, Domain and
discretization protocols (``loop``) over the NumPy core of this package.

* ``SavageHutterFlow`` — the Model: the state (h, q = h ū) on the 1D grid, one explicit step
  of ``scheme`` (order 1: forward Euler; order 2: Heun, which may take a shorter step than
  asked — reported as ``StepReport.dt``), accept/reject, snapshot/transfer;
* ``SavageHutterDiscretization`` — what lives on the grid: the flow, the measures of the
  stop rules (threshold front, max height, mass, kinetic energy, an exact fixed point), the
  step limit of the scheme (CFL and positivity of h: ``scheme.interface_terms``), and the
  output fields h(x), ū(x) on a DOLFINx interval mesh of the grid (XDMF, cell data);
* ``SavageHutterFactory`` — the model of ``model.name = savage_hutter``: a fixed 1D domain,
  the initial state of the config (``setup.setup_from_config``), its checkpoints.

Under MPI every rank steps the same (small) arrays, so all ranks hold the same state, take
the same steps and stop with the same exit code; the output mesh is distributed and each
rank writes the cells it owns; rank 0 writes checkpoints and diagnostics.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
from dolfinx import fem

from dpcollapse import compat
from dpcollapse.domain.fixed import FixedDomain
from dpcollapse.errors import ConfigError, ConvergenceError
from dpcollapse.io.checkpoint import choose_checkpoint, write_npz_atomic
from dpcollapse.models.base import DiscretizationDefaults
from dpcollapse.models.savage_hutter.scheme import interface_terms, update, velocity
from dpcollapse.models.savage_hutter.setup import SavageHutterSetup, setup_from_config
from dpcollapse.models.savage_hutter.solver import _heun_step, front_position, wet_front_position

#: Arrays of a depth-averaged checkpoint (checkpoint.npz).
CHECKPOINT_KEYS = ("thickness", "momentum", "outflow", "grid", "state")


@dataclass
class StepReport:
    """An explicit step: always one iteration; ``dt`` the step actually taken [s]."""

    converged: bool
    iterations: int
    residual: float
    message: str = ""
    dt: float | None = None


class SavageHutterFlow:
    """The Model protocol (``models.base``) for the depth-averaged state (h, q) [m, m²/s]."""

    exported_cell_fields = ()
    #: an explicit step is one "iteration" (the adaptive step rule of the loop)
    iteration_scale = 1

    def local_error(self) -> None:
        """No local error estimate (``time.tolerance`` is the 2D model's)."""

    def __init__(self, setup: SavageHutterSetup):
        self.setup = setup
        self.model, self.grid = setup.model, setup.grid
        self.phys = self.model.physics()
        self.h = setup.h0.copy()
        self.q = np.zeros_like(self.h)
        self.outflow = 0.0       # mass that left through open ends [m²]
        self.fixed_point = False  # the last accepted step left an exact rest state
        self._terms = None       # interface terms of the accepted state (cached)
        self._trial = None

    # the state's interface terms: fluxes, locking and the admissible step
    def terms(self):
        if self._terms is None:
            m = self.model
            self._terms = interface_terms(self.h, self.q, self.phys, self.grid.dx, m.cfl,
                                          m.left, m.right, m.order)
        return self._terms

    def set_velocity(self, profile) -> None:
        """The initial state is at rest (the config refuses other initial velocities)."""
        self.q[:] = 0.0

    def solve_step(self, dt: float) -> StepReport:
        terms = self.terms()
        dx, m = self.grid.dx, self.model
        rest_before = not self.q.any() and not terms.mass_flux.any()
        if m.order == 1:
            lost = dt * (float(terms.mass_flux[-1]) - float(terms.mass_flux[0]))
            h, q = update(self.h, self.q, terms, self.phys, dx, dt)
        else:
            h, q, dt, lost = _heun_step(self.h, self.q, terms, dt, self.phys, m, dx)
        if not (np.isfinite(q).all() and np.isfinite(h).all()):
            raise ConvergenceError(f"the depth-averaged scheme produced a non-finite state "
                                   f"with dt = {dt:.3e} s (model.cfl = {m.cfl:g})")
        self._trial = (h, q, lost, rest_before and not q.any())
        return StepReport(True, 1, 0.0, dt=dt)

    def accept_step(self) -> None:
        self.h, self.q, lost, self.fixed_point = self._trial
        self.outflow += lost
        self._trial, self._terms = None, None

    def reset_iterate(self) -> None:
        self._trial = None

    def snapshot(self) -> dict:
        return {"thickness": self.h.copy(), "momentum": self.q.copy(),
                "outflow": np.array(self.outflow)}

    def transfer(self, fields: dict) -> float:
        """Take a snapshot of the same grid (a checkpoint); returns 0 (no extrapolation)."""
        h, q = np.asarray(fields["thickness"], float), np.asarray(fields["momentum"], float)
        if h.shape != self.h.shape or q.shape != self.q.shape:
            raise ConfigError(f"--resume: the checkpoint has {h.size} cells, model.n_cells = "
                              f"{self.h.size}; start the run again with --overwrite")
        self.h, self.q = h.copy(), q.copy()
        self.outflow = float(fields.get("outflow", 0.0))
        self._terms = self._trial = None
        return 0.0

    def copy_state_from(self, other) -> None:
        self.transfer(other.snapshot())

    def velocity(self) -> np.ndarray:
        """ū per cell [m/s] (0 where dry)."""
        return velocity(self.h, self.q, self.model.h_dry)

    def cell_field(self, name: str) -> np.ndarray:
        raise KeyError(name)

    def destroy(self) -> None:
        pass


class SavageHutterDiscretization(DiscretizationDefaults):
    """The flow on its grid, its measures, step limit and output fields (``loop``)."""

    #: measures beyond the shared ones: diagnostics columns and run.json summary entries
    extra_measures = ("wet_front", "outflow")

    def __init__(self, setup: SavageHutterSetup, comm, density: float):
        self.comm, self.density = comm, density
        self.grid, self.model = setup.grid, setup.model
        self.flow = SavageHutterFlow(setup)
        self.tagged = None
        #: the thickness that makes the front [m] (run.json, beside the 2D model's)
        self.film_threshold = self.model.front_threshold
        self.mesh = compat.create_interval_mesh(comm, self.grid.edges)
        S0 = compat.scalar_space(self.mesh, 0, "DG")
        self.out_thickness = fem.Function(S0, name="thickness")
        self.out_velocity = fem.Function(S0, name="velocity")
        n = compat.num_owned_cells(self.mesh)
        centres = self.mesh.geometry.x[:, 0][compat.geometry_dofmap(self.mesh)[:n]].mean(axis=1)
        self._dofs = compat.cell_dofs(S0)[:n, 0]
        self._index = np.clip(np.floor((centres - self.grid.x_min) / self.grid.dx).astype(int),
                              0, self.grid.n_cells - 1)
        theta = math.radians(self.model.slope_deg)
        self._g_sin, self._g_cos = self.model.g * math.sin(theta), self.model.g * math.cos(theta)

    def area(self) -> float:
        """Mass per unit width in the domain Σ h Δx [m²]."""
        return float(np.sum(self.flow.h) * self.grid.dx)

    def max_step(self) -> float:
        """The scheme's step limit: CFL on the fastest wave and positivity of h [s]."""
        return self.flow.terms().dt_max

    def courant_rate(self) -> float:
        """1/(the hard step bound: CFL 1 and positivity) [1/s]; Δt × this ≤ model.cfl."""
        hard = self.flow.terms().dt_hard
        return 1.0 / hard if hard > 0 and math.isfinite(hard) else 0.0

    def measures(self) -> dict:
        """Front (furthest x where h crosses model.front_threshold; also the thickness front
        ``thick_front`` of the 2D model), max height, kinetic
        energy ρ Σ α h ū²/2 Δx [J/m], gravity's moment ρ Σ g (sinθ x h − cosθ h²/2) Δx [J/m],
        mass [m²], max |ū|, whether the state is an exact rest state (``at_rest``)."""
        flow, grid = self.flow, self.grid
        h, u = flow.h, flow.velocity()
        dx, rho = grid.dx, self.density
        front = front_position(h, grid, self.model.front_threshold)
        front = float(front) if math.isfinite(front) else grid.x_min
        return {
            "front": front,
            "thick_front": front,     # the front is already a thickness threshold
            "max_height": float(np.max(h)),
            "kinetic_energy": float(0.5 * rho * self.model.shape_factor * np.sum(h * u * u) * dx),
            "gravity_moment": float(rho * np.sum(self._g_sin * grid.centers * h
                                                 - 0.5 * self._g_cos * h * h) * dx),
            "area": self.area(),
            "max_speed": float(np.max(np.abs(u))),
            "wet_front": float(wet_front_position(h, grid, self.model.h_dry)),
            "outflow": flow.outflow,
            "at_rest": flow.fixed_point,
        }

    def output_functions(self) -> list:
        """h(x) [m] and ū(x) [m/s] as cell data of the interval mesh."""
        self.out_thickness.x.array[self._dofs] = self.flow.h[self._index]
        self.out_velocity.x.array[self._dofs] = self.flow.velocity()[self._index]
        return [self.out_thickness, self.out_velocity]

    def exact_rest(self, measures: dict) -> bool:
        """The state is a fixed point of the scheme (every ū = 0, no mass crosses a face)."""
        return bool(measures["at_rest"])

    def solver_counts(self) -> dict[str, int]:
        """An explicit scheme: no linear solver, no counters."""
        return {}

    def destroy(self) -> None:
        pass


class SavageHutterFactory:
    """The depth-averaged model of a config (``model.name = savage_hutter``) for the loop."""

    model_name = "savage_hutter"
    #: whether its mesh is the scene's own (``dpcollapse mesh`` writes it)
    meshes_the_scene = False

    def __init__(self, cfg):
        self.cfg = cfg
        self.setup = setup_from_config(cfg)

    @classmethod
    def from_config(cls, cfg) -> SavageHutterFactory:
        return cls(cfg)

    @staticmethod
    def describe(cfg) -> list[str]:
        """The lines of ``dpcollapse check``: the model, its grid, the mass, the time steps."""
        sh, t = setup_from_config(cfg), cfg.time
        return [f"depth-averaged Savage-Hutter model: basal friction {sh.model.basal.describe()} "
                f"(from the {sh.friction}), slope {sh.model.slope_deg:g} deg, alpha = "
                f"{sh.model.shape_factor:g}, order {sh.model.order}",
                f"grid: {sh.grid.n_cells} cells on [{sh.grid.x_min:g}, {sh.grid.x_max:g}] m "
                f"(dx = {sh.grid.dx:.4g} m), {cfg.model.left} / {cfg.model.right} ends, "
                f"CFL {sh.model.cfl:g}",
                cfg.geometry.describe(),
                f"time: steps of at most {t.dt:g} s (the CFL limit rules below it), "
                f"end {t.end_time:g} s"]

    def domain(self) -> FixedDomain:
        """A fixed 1D grid: nothing moves, nothing is remeshed."""
        return FixedDomain()

    def start(self, comm) -> SavageHutterDiscretization:
        return SavageHutterDiscretization(self.setup, comm, self.cfg.material.density)

    def rebuild(self, tagged):
        raise NotImplementedError("a fixed 1D grid is never rebuilt")

    def save_checkpoint(self, path, disc: SavageHutterDiscretization, state: dict) -> None:
        """Rank 0 writes h, q, the outflow, the grid and the loop state (atomically)."""
        if disc.comm.rank != 0:
            return
        g = disc.grid
        arrays = {k: v for k, v in disc.flow.snapshot().items()}
        arrays["grid"] = np.array([g.x_min, g.x_max, g.n_cells], dtype=float)
        arrays["state"] = np.array(json.dumps(state))
        write_npz_atomic(path, arrays)

    def load_checkpoint(self, path, comm) -> tuple[SavageHutterDiscretization, dict]:
        """The discretization and loop state of a checkpoint (read by every rank)."""
        chosen = choose_checkpoint(path, comm, required=CHECKPOINT_KEYS)
        with np.load(chosen) as data:
            fields = {k: data[k] for k in ("thickness", "momentum", "outflow")}
            grid, state = data["grid"], json.loads(str(data["state"]))
        g = self.setup.grid
        if not np.allclose(grid, [g.x_min, g.x_max, g.n_cells], rtol=0, atol=1e-12):
            raise ConfigError(f"--resume: the checkpoint's grid {list(grid)} is not the config's "
                              f"[{g.x_min}, {g.x_max}, {g.n_cells}]; start again with --overwrite")
        disc = self.start(comm)
        disc.flow.transfer(fields)
        return disc, state
