"""Pieces of the time loop that do not depend on the model: what it asks of a model
(``ModelFactory``, ``Discretization``; of a domain: ``domain.base.Domain``), its typed state
(what a checkpoint stores) and its events.

The loop knows no model: everything a model or a domain adds to a run is declared here —
its step limit (``max_step``), its local error estimate (``flow.local_error``) and iteration
scale (``flow.iteration_scale``), the step it actually took (``report.dt``), its own stop
reason (``stop_reason``: the silo's ``emptied``), the area its mass balance counts
(``mass_area``: with what left through an outflow), its exact rest state (``exact_rest``),
its diagnostics columns
(``extra_measures``), its run.json entries (``summary_measures``; the domain's
``counters``), its check of an accepted step (the moving domain's energy guard,
``Domain.check_step``) and its named events (``counted_events``, ``take_events``: the moving
domain's landings; a remesh's surgery, a model's outflow …), which the loop counts into
diagnostics.csv and run.json without knowing their names.

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

import numpy as np

#: the measures every model's ``measures()`` gives (the loop reads no other; the model's
#: own are its ``extra_measures``)
MEASURES = ("front", "thick_front", "max_height", "kinetic_energy", "gravity_moment", "area",
            "max_speed")


class Discretization(Protocol):
    """A model on its current mesh or grid, as the loop (``simulation``) uses it.

    ``flow`` is the model (``models.base.Model``: solve_step → a report with converged,
    iterations, residual, message and ``dt``, the step actually taken when an explicit stage
    bound cut it, else None; accept_step, reset_iterate, snapshot/transfer, copy_state_from,
    ``iteration_scale``, ``local_error()``). ``solver_counts()`` gives the counters of its
    solvers by run.json name (flow_factorizations, krylov_iterations, newton_fallbacks; none
    for a model that solves no linear system). ``measures()`` returns at least front,
    thick_front, max_height [m], kinetic_energy, gravity_moment [J/m], area [m²], max_speed
    [m/s], the model's own ``extra_measures`` (its diagnostics columns and run.json entries:
    the 2D model's mesh quality min_angle [deg], min_detJ and μ(I)'s ill_posed_fraction, the
    depth-averaged wet_front, the two-phase fraction bounds …); the loop reads
    ``MEASURES`` only. ``exact_rest(measures)``: the state is an exact rest state (the run
    stops once max |u| < time.rest_speed). ``summary_measures()``: run.json entries computed
    over the whole run (the silo's steady discharge), {} for none. ``stop_reason(measures)``:
    the run's status when the model's own rule ends it after this step (the silo:
    ``emptied``), else None.
    ``mass_area(measures)``: the area A [m²] the mass balance compares with the initial one,
    area_drift = (A − A₀)/A₀ — the area inside plus what left through an outflow side.
    ``counted_events``/``take_events()``: as ``EventSource``."""

    flow: object
    mesh: object
    tagged: object
    extra_measures: tuple[str, ...]
    counted_events: tuple[str, ...]
    #: the panel ``dpcollapse plot`` draws its diagnostics over time in: front (front and
    #: max height) or discharge (a bin's Q, −dm/dt and fill height); run.json's ``history_plot``
    history_plot: str
    #: the thickness [m] above which the mass counts for the thickness front ``thick_front``
    film_threshold: float

    def measures(self) -> dict: ...

    def solver_counts(self) -> dict[str, int]: ...

    def summary_measures(self) -> dict: ...

    def stop_reason(self, measures: dict) -> str | None: ...

    def exact_rest(self, measures: dict) -> bool: ...

    def mass_area(self, measures: dict) -> float: ...

    def take_events(self) -> dict[str, int]: ...

    def area(self) -> float: ...

    def max_step(self) -> float:
        """The model's own step limit [s] (inf: none)."""

    def courant_rate(self) -> float:
        """max |u|/cell size, or the scheme's wave-speed equivalent [1/s]."""

    def output_functions(self) -> list:
        """The fields to write (P1 or DG0 functions on ``mesh``)."""

    def destroy(self) -> None: ...


class EventSource(Protocol):
    """A domain or a discretization that reports named events (the moving domain: nose nodes
    that landed on the bed, ``landings``). ``counted_events`` declares their names (the
    columns of diagnostics.csv and entries of run.json, counted over the run from 0);
    ``take_events()`` gives the counts since its last call, of accepted work only (an undone
    attempt's events are dropped by the source). The loop calls it after every accepted
    step."""

    counted_events: tuple[str, ...]

    def take_events(self) -> dict[str, int]: ...


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
    #: kinetic energy of the previous step [J/m]
    checkpoint_step: int | None = None
    remesh_angle_after: float | None = None
    kinetic_energy_previous: float | None = None
    #: the largest kinetic energy so far [J/m] (the rest rule time.rest_energy_fraction;
    #: in the checkpoint so that a resumed run stops where the uninterrupted one does)
    kinetic_energy_peak: float | None = None
    #: the moving domain's thickness-front window since the last remesh, [t0, x0, speed]
    #: ([s], [m], [m/s]; speed None while unknown): in the checkpoint so that a resumed run's
    #: film trim chooses its cut face as the uninterrupted one does (``MovingDomain``)
    front_window: list | None = None
    #: the error-controlled step's controller (``StepController.record``: its last estimate
    #: and rejections), so that a resumed run takes the uninterrupted run's steps
    step_controller: dict | None = None
    #: counts of the named events of the domain and the model (``EventSource``), stored as
    #: entries of their own (a checkpoint's ``landings``, as before events were named)
    event_counts: dict = field(default_factory=dict)
    #: entries of a checkpoint this version does not know, kept and written back
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = dataclasses.asdict(self)
        extra, counts = out.pop("extra"), out.pop("event_counts")
        return {**extra, **counts, **{k: v for k, v in out.items() if v is not None}}

    @classmethod
    def from_dict(cls, data: dict) -> LoopState:
        names = {f.name for f in dataclasses.fields(cls)} - {"extra", "event_counts"}
        known = {k: v for k, v in data.items() if k in names}
        return cls(**known, extra={k: v for k, v in data.items() if k not in names})

    def count_events(self, names: tuple[str, ...]) -> None:
        """Start counting the events ``names``: a count a checkpoint stored (kept in
        ``extra`` by ``from_dict``) continues, a new one starts at 0."""
        for name in names:
            stored = self.extra.pop(name, 0) or 0   # a count (int) or an amount (float)
            self.event_counts[name] = stored + self.event_counts.get(name, 0)

    def add_events(self, counts: dict[str, int]) -> None:
        for name, n in counts.items():
            self.event_counts[name] = self.event_counts.get(name, 0) + n


def run_summary(status: str, state: LoopState, measures: dict, disc: Discretization,
                iterations: list[int], counters: dict) -> dict:
    """run.json's summary: the loop's state and the shared measures of the last step, the
    area drift (A − A₀)/A₀ of the model's ``mass_area``, the event counts, the fixed-point
    iterations per step, ``counters`` (the solvers', the domain's, the step rules'), then the
    model's ``extra_measures`` (NaN, a measure it does not have, as None) and its
    ``summary_measures``."""
    m, its = measures, iterations
    summary = {
        "status": status, "t": state.t, "steps": state.step, "remeshes": state.remeshes,
        "front": m["front"], "max_height": m["max_height"], "thick_front": m["thick_front"],
        "film_threshold": disc.film_threshold, **state.event_counts, "area": m["area"],
        "area_drift": (disc.mass_area(m) - state.area0) / state.area0,
        "kinetic_energy": m["kinetic_energy"],
        "mean_iterations": float(np.mean(its)) if its else 0.0,
        "max_iterations": int(np.max(its)) if its else 0,
        "flow_solves": int(np.sum(its)) if its else 0,
        **counters,
    }
    summary.update({k: m[k] if m[k] == m[k] else None for k in disc.extra_measures})
    summary.update(disc.summary_measures())   # the model's own
    return summary
