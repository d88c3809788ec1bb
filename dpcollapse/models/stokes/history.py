"""The past of a Stokes flow on one mesh that the second-order time scheme uses.

``time.scheme: bdf2`` (``solvers.bdf``): the velocities u^{n−1}, u^{n−2} of the last
accepted steps (dof values of the same nodes, which move with the mesh: the values along
the node trajectories), their steps, and the mesh-velocity dof positions x^n, x^{n−1}.
The history starts empty on a new mesh (start, remesh): the first step there is BDF1 with
the mesh moved by w(uⁿ), then BDF2. A landing rebuild (same mesh, same dofs, new facet tags)
copies it; a checkpoint stores it (``record`` and the fields of ``models.stokes.state``), so
a resumed run takes the uninterrupted run's steps. The error estimate waits until the three past velocities it
uses were all solved on the current mesh with the current conditions (three steps after a
remesh or a landing): a transferred field's interpolation error, or the jump of the nodes
that landed (u·n = 0 from then on), is no time-discretization error.
"""

from __future__ import annotations

import numpy as np

from dpcollapse.solvers.bdf import bdf2_coefficients, midpoint_weights, milne_factor, predictor_weights


class TimeHistory:
    """u^{n−1}, u^{n−2} (flat dof arrays), Δt_{n−1}, Δt_{n−2}, and x^n, x^{n−1} (dof positions)."""

    def __init__(self, positions: np.ndarray):
        self.velocities: list[np.ndarray] = []   # [u^{n−1}, u^{n−2}]
        self.steps: list[float] = []             # [Δt_{n−1}, Δt_{n−2}]
        self.positions: list[np.ndarray] = [positions.copy()]  # [xⁿ, x^{n−1}]
        self.solved = 0   # steps accepted since the mesh or its conditions changed

    @property
    def previous_step(self) -> float | None:
        return self.steps[0] if self.steps else None

    def push(self, u_accepted_before: np.ndarray, dt: float, positions: np.ndarray) -> None:
        """After an accepted step of size ``dt`` from uⁿ = ``u_accepted_before`` to the mesh
        ``positions``: shift the history by one step."""
        self.velocities = [u_accepted_before.copy()] + self.velocities[:1]
        self.steps = [dt] + self.steps[:1]
        self.positions = [positions.copy()] + self.positions[:1]
        self.solved += 1

    def copy_from(self, other: TimeHistory) -> None:
        """The history of the flow on the same mesh before a landing (its estimate restarts)."""
        self.solved = 0
        self.velocities = [v.copy() for v in other.velocities]
        self.steps = list(other.steps)
        self.positions = [x.copy() for x in other.positions]

    def record(self) -> dict:
        """The history's numbers for a checkpoint (JSON): past steps and the solved count
        (the arrays go in as fields of the mesh)."""
        return {"steps": list(self.steps), "solved": self.solved}

    def restore(self, record: dict, velocities: list[np.ndarray],
                previous_positions: np.ndarray | None) -> None:
        """The history of a checkpoint on its own mesh: ``record`` (``record``), u^{n−1},
        u^{n−2} as far as stored and x^{n−1} (None: not stored)."""
        self.steps = [float(dt) for dt in record["steps"]]
        self.solved = int(record["solved"])
        self.velocities = [u.copy() for u in velocities]
        if previous_positions is not None:
            self.positions = [self.positions[0], previous_positions.copy()]

    def coefficients(self, dt: float) -> tuple[float, float, float]:
        """BDF2's (α₀, α₁, α₂) for a step ``dt`` (BDF1 without history)."""
        return bdf2_coefficients(dt, self.previous_step)

    def effective_old(self, u_now: np.ndarray, dt: float) -> np.ndarray:
        """ŷ = (α₁ uⁿ − α₂ u^{n−1})/α₀ (uⁿ without history)."""
        a0, a1, a2 = self.coefficients(dt)
        if not self.velocities:
            return u_now.copy()
        return (a1 * u_now - a2 * self.velocities[0]) / a0

    def midpoint(self, u_now: np.ndarray, dt: float) -> np.ndarray:
        """u* ≈ u(tⁿ + Δt/2), extrapolated (uⁿ without history)."""
        a, b = midpoint_weights(dt, self.previous_step)
        if not self.velocities:
            return u_now.copy()
        return a * u_now + b * self.velocities[0]

    def mesh_velocity(self, positions: np.ndarray, dt: float) -> np.ndarray | None:
        """w^{n+1} = (α₀ x^{n+1} − α₁ xⁿ + α₂ x^{n−1})/Δt of the dofs at ``positions``
        (x^{n+1}), the node velocity consistent with the BDF2 derivative; None without
        x^{n−1} (then the motion's own w, (x^{n+1} − xⁿ)/Δt, is consistent)."""
        if len(self.positions) < 2 or not self.steps:
            return None
        a0, a1, a2 = self.coefficients(dt)
        return (a0 * positions - a1 * self.positions[0] + a2 * self.positions[1]) / dt

    def local_error(self, u_new: np.ndarray, u_now: np.ndarray, dt: float) -> np.ndarray | None:
        """The estimated local error of the BDF2 step (dof values; None until the three past
        velocities were solved here: three accepted steps on this mesh and conditions)."""
        if len(self.velocities) < 2 or self.solved < 3:
            return None
        dt1, dt2 = self.steps
        w = predictor_weights(dt, dt1, dt2)
        predicted = w[0] * u_now + w[1] * self.velocities[0] + w[2] * self.velocities[1]
        return milne_factor(dt, dt1, dt2) * (u_new - predicted)
