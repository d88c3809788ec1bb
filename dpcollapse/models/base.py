"""What the time loop asks of a model on one mesh (``Model``).

A model holds its state as named fields, takes a time step and reports on it, and is
accepted or rejected by the loop; a remesh carries its state to a new mesh through a
mesh-independent snapshot. The loop (``simulation``) and the moving domain (``ale.motion``,
which reads ``motion_source`` and writes ``mesh_velocity``: ``MovingModel``) use nothing
else. ``DiscretizationDefaults``: what a discretization (``loop.Discretization``) without a
stop rule, events or run.json entries of its own answers the loop.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Model(Protocol):
    #: the accepted velocity uⁿ and the mesh velocity w (moving domains)
    u_old: object
    mesh_velocity: object
    #: per-cell fields it exports (see ``cell_field``)
    exported_cell_fields: tuple[str, ...]
    #: the cost of one of its iterations relative to a factorization (the adaptive step's
    #: thresholds on iterations are multiplied by it)
    iteration_scale: float

    def local_error(self) -> float | None:
        """The local error estimate of the last solved step [m/s] (``time.tolerance``), None
        where it has none (BDF1, the first steps of BDF2, an explicit scheme)."""

    def set_velocity(self, profile) -> None:
        """The initial state: uⁿ = profile(x)."""

    def solve_step(self, dt: float):
        """One step of size dt on the current mesh: a report with ``converged``,
        ``iterations``, ``residual`` and ``message``."""

    def accept_step(self) -> None:
        """The step's solution becomes the accepted state."""

    def reset_iterate(self) -> None:
        """Reject the step: start again from the accepted state."""

    def snapshot(self) -> dict:
        """The accepted state as named mesh-independent fields."""

    def transfer(self, fields: dict) -> float:
        """Take the state from a snapshot of another mesh; the largest extrapolation [m]."""

    def copy_state_from(self, other) -> None:
        """Take the state of a model on the same mesh and dofs (new facet tags)."""

    def cell_field(self, name: str) -> np.ndarray:
        """Values per local cell of an exported cell field."""

    def destroy(self) -> None:
        """Free the PETSc objects."""


class MovingModel(Model, Protocol):
    """A model on a domain that moves with it (``domain.moving``, ``ale.motion``)."""

    #: ``time.scheme``: bdf1, or bdf2 (then the mesh velocity depends on the step)
    scheme: str
    #: the velocity whose boundary motion the mesh follows (uⁿ, or BDF2's u*)
    motion_source: object

    def prepare_motion(self, dt: float | None) -> bool:
        """Make ``motion_source`` that of a step ``dt``; whether the mesh motion is to be
        second order (the explicit midpoint rule)."""


class DiscretizationDefaults:
    """The answers of a discretization (``loop.Discretization``) with no events, stop rule,
    outflow or run.json entries of its own and no exact rest state."""

    #: the names of the events it reports (``loop.EventSource``)
    counted_events: tuple[str, ...] = ()
    #: the panel ``dpcollapse plot`` draws its diagnostics over time in (``plot.HISTORY_PLOTS``)
    history_plot = "front"

    def take_events(self) -> dict[str, int]:
        return {}

    def stop_reason(self, measures: dict) -> str | None:
        """No stop rule of its own."""
        return None

    def exact_rest(self, measures: dict) -> bool:
        """Not an exact rest state: the loop's rest rule alone."""
        return False

    def mass_area(self, measures: dict) -> float:
        """A closed mass: its area [m²]."""
        return measures["area"]

    def summary_measures(self) -> dict:
        """No run.json entries beyond the per-step measures."""
        return {}
