"""Pieces of the time loop that do not depend on the model: what it asks of a model
(``ModelFactory``, ``Discretization``), its typed state (what a checkpoint stores) and its
events.

Events (``Events.emit``) of a run, in the order they happen:

- ``discretization(sim, disc)``: a new mesh with its model is in use (start, resume, remesh,
  landing rebuild) — benchmarks collect its solver statistics from here;
- ``step_accepted(sim, row)``: a step is accepted; ``row`` is its diagnostics row. A
  subscriber that returns True ends the run cleanly after this step (files written as at
  rest, status "stopped_by_observer"); under MPI it must return the same on every rank;
- ``output(sim, t)``: fields written at time t;
- ``remesh(sim, info)``: the domain was remeshed (``info``: reason, areas, cells);
- ``failure(sim, error)``: the run stops on a solver or mesh failure (before it is raised).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

class Discretization(Protocol):
    """A model on its current mesh or grid, as the loop (``simulation``) uses it.

    ``flow`` is the model (``models.base.Model``: solve_step → a report with converged,
    iterations, residual, message and optionally ``dt``, the step actually taken when an
    explicit stage bound cut it; accept_step, reset_iterate, snapshot/transfer,
    copy_state_from, ``iteration_scale``). ``solver_counts()`` gives the counters of its
    solvers by run.json name (flow_factorizations, krylov_iterations, newton_fallbacks; none
    for a model that solves no linear system). ``measures()`` returns at least front,
    thick_front, max_height [m], kinetic_energy, gravity_moment [J/m], area [m²], max_speed
    [m/s], the model's own ``extra_measures`` (its diagnostics columns and run.json entries:
    the 2D model's mesh quality min_angle [deg], min_detJ and μ(I)'s ill_posed_fraction, the
    depth-averaged wet_front, the two-phase fraction bounds …) and optionally ``at_rest``
    (the state is an exact rest state: the run stops once max |u| < time.rest_speed).
    ``summary_measures()``: run.json entries computed over the whole run (the silo's
    steady discharge), {} for none."""

    flow: object
    mesh: object
    tagged: object
    extra_measures: tuple[str, ...]
    #: the thickness [m] above which the mass counts for the thickness front ``thick_front``
    film_threshold: float

    def measures(self) -> dict: ...

    def solver_counts(self) -> dict[str, int]: ...

    def summary_measures(self) -> dict: ...

    def area(self) -> float: ...

    def max_step(self) -> float:
        """The model's own step limit [s] (inf: none)."""

    def courant_rate(self) -> float:
        """max |u|/cell size, or the scheme's wave-speed equivalent [1/s]."""

    def output_functions(self) -> list:
        """The fields to write (P1 or DG0 functions on ``mesh``)."""

    def destroy(self) -> None: ...


class ModelFactory(Protocol):
    """The model of ``model.name`` (``models.registry.model_factory``): its domain
    (``domain.base.Domain``), its initial discretization, a new one on a new mesh (remesh
    or new facet tags), and its checkpoints (the loop state is a JSON-able dict)."""

    model_name: str

    def domain(self): ...

    def start(self, comm) -> Discretization: ...

    def rebuild(self, tagged) -> Discretization: ...

    def save_checkpoint(self, path, disc: Discretization, state: dict) -> None: ...

    def load_checkpoint(self, path, comm) -> tuple[Discretization, dict]: ...


EVENTS = ("discretization", "step_accepted", "output", "remesh", "failure")


class Events:
    """Subscribers by event name; ``emit`` calls them in subscription order."""

    def __init__(self):
        self._subscribers: dict[str, list[Callable]] = {name: [] for name in EVENTS}

    def subscribe(self, name: str, callback: Callable) -> Callable:
        if name not in self._subscribers:
            raise ValueError(f"unknown event {name!r}; events: {', '.join(EVENTS)}")
        self._subscribers[name].append(callback)
        return callback

    def emit(self, name: str, *args) -> list:
        """Call every subscriber of ``name``; their return values."""
        return [callback(*args) for callback in self._subscribers[name]]


@dataclass
class LoopState:
    """The state of the time loop: what a checkpoint stores besides the fields.

    Saved as a JSON object (``to_dict``); optional entries are left out while unset, as
    the dict state of earlier versions did, so old checkpoints load (``from_dict``).
    """

    t: float = 0.0                 # [s]
    step: int = 0
    dt_target: float = 0.0         # [s] the step size aimed at next
    rest_time: float = 0.0         # [s] how long max |u| has stayed below the rest speed
    remeshes: int = 0
    last_remesh_step: int = -10**9
    area0: float = 0.0             # [m²] of the initial mass
    gravity_moment0: float = 0.0   # ρ∫f·x dx at t = 0 [J/m]
    kinetic_energy0: float = 0.0   # [J/m]
    status: str = "running"
    #: optional: step of the last checkpoint; smallest angle a remesh left [deg];
    #: kinetic energy of the previous step [J/m]; nose nodes that landed on the bed
    checkpoint_step: int | None = None
    remesh_angle_after: float | None = None
    kinetic_energy_previous: float | None = None
    landings: int | None = None
    #: boundary surgeries done by remeshes and the sum of their area changes [m²]
    surgeries: int | None = None
    surgery_area_change: float | None = None
    #: the largest kinetic energy so far [J/m] (the rest rule time.rest_energy_fraction;
    #: in the checkpoint so that a resumed run stops where the uninterrupted one does)
    kinetic_energy_peak: float | None = None
    #: the error-controlled step's controller (``StepController.record``: its last estimate
    #: and rejections), so that a resumed run takes the uninterrupted run's steps
    step_controller: dict | None = None
    #: entries of a checkpoint this version does not know, kept and written back
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "extra"}
        out = {k: v for k, v in out.items() if v is not None}
        return {**self.extra, **out}

    @classmethod
    def from_dict(cls, data: dict) -> LoopState:
        names = {f.name for f in dataclasses.fields(cls)} - {"extra"}
        known = {k: v for k, v in data.items() if k in names}
        return cls(**known, extra={k: v for k, v in data.items() if k not in names})
