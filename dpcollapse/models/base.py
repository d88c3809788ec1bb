"""What the time loop asks of a model on one mesh (``Model``).

A model holds its state as named fields, takes a time step and reports on it, and is
accepted or rejected by the loop; a remesh carries its state to a new mesh through a
mesh-independent snapshot. The loop (``simulation``) and the moving domain (``ale.motion``,
which reads ``u_old`` and writes ``mesh_velocity``) use nothing else.
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
