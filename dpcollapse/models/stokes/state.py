"""The state of a Stokes model on one mesh, and the plumbing both Stokes models share.

Named fields on Taylor–Hood P2/P1 (``W``) and P1 (``Vw``)::

    solution        (u^{n+1,k+1}, p^{n+1,k+1})   the last iterate's solve
    iterate         (u^{n+1,k},   p^{n+1,k})     the coefficients of the next solve
    u_old           uⁿ                            the accepted velocity
    mesh_velocity   w                             of a moving domain (zero on a fixed one)

plus, for a model that carries them, multipliers (``multiplier_functions``). The Dirichlet
conditions come from the scene's boundaries (no slip; u·n = 0 on an axis-parallel side), the
periodic constraint from its periodic pair. ``StokesState`` is the base of both models
(``regularized``, ``augmented``); neither inherits from the other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.free_surface import set_nodal_values, surface_tension_nodes
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.io.checkpoint import note_not_restored
from dpcollapse.models.stokes.history import TimeHistory
from dpcollapse.rheology.base import Rheology
from dpcollapse.rheology.coordinates import PLANAR, Planar
from dpcollapse.scenes.base import SOLID, Boundary, BoundaryKind
from dpcollapse.solvers.assembly import LinearSystem, zero_dirichlet
from dpcollapse.transfer import CellwiseField, concatenate


@dataclass(frozen=True)
class FlowParameters:
    """Physical parameters of a scene, SI units."""

    density: float            # ρ [kg/m³]
    gravity: float            # g [m/s²]
    bed_angle: float          # θ [rad]
    rheology: Rheology        # the constitutive law (rheology.base)
    boundaries: tuple[Boundary, ...] = ()  # of the scene (scenes.base): kind, normal, μ per tag
    channel_width: float | None = None  # w: side-wall friction (2/w) μ_w p u/|u| when given
    mu_side: float = 0.0      # μ_w
    surface_tension: float = 0.0         # γ̄0 [N/m] of seed 000's local surface tension (0: off)
    surface_tension_extent: float = 3.0  # δ [free-surface nodes]
    coordinates: Planar = PLANAR         # geometry.symmetry: planar, or axisymmetric (x = r, y = z)

    def __post_init__(self):
        law_coordinates = getattr(self.rheology, "coordinates", PLANAR)
        if law_coordinates != self.coordinates:
            raise ValueError(f"the law's coordinates ({law_coordinates!r}) are not the flow's "
                             f"({self.coordinates!r})")

    def of_kind(self, *kinds: BoundaryKind) -> list[Boundary]:
        """The boundaries of the given kinds, in the scene's order."""
        return [b for b in self.boundaries if b.kind in kinds]

    @property
    def periodic_slave(self) -> Boundary | None:
        """The side tied to its periodic image (the one with a translation), if any."""
        return next((b for b in self.of_kind(BoundaryKind.PERIODIC) if b.translation), None)

    @property
    def body_force(self) -> tuple[float, float]:
        """f = g (sin θ, −cos θ) in slope coordinates."""
        return (self.gravity * math.sin(self.bed_angle), -self.gravity * math.cos(self.bed_angle))


@dataclass
class StepReport:
    converged: bool
    iterations: int
    residual: float        # estimated error of the last iterate relative to the RMS velocity
    message: str = ""
    dt: float | None = None   # the step taken [s], when shorter than asked (never: implicit)


#: Largest contraction factor used in the error estimate of the fixed point.
CONTRACTION_CAP = 0.99


def contraction(change: float, previous: float) -> float:
    """ρ = ‖Δ_k‖/‖Δ_{k−1}‖ of successive increments, capped at CONTRACTION_CAP (0 without
    a previous increment)."""
    return min(change / previous, CONTRACTION_CAP) if previous > 0 else 0.0


def distance_to_limit(change: float, rho: float) -> float:
    """Estimated distance of a linearly converging iterate to its limit, Δ max(1, ρ/(1 − ρ))."""
    return change * max(1.0, rho / (1.0 - rho))



class StokesState:
    """Spaces, named fields, conditions and state access of a Stokes model on one mesh."""

    @staticmethod
    def describe(cfg) -> list[str]:
        """The flow method's own lines of ``dpcollapse check`` (none here)."""
        return []

    def solver_counts(self) -> dict[str, int]:
        """Its linear solver's counters by run.json name."""
        return {"flow_factorizations": self.solver.factorizations,
                "krylov_iterations": self.solver.krylov_iterations,
                "newton_fallbacks": self.solver.fallbacks}

    def __init__(self, tagged: TaggedMesh, params: FlowParameters):
        self.tagged = tagged
        self.mesh = mesh = tagged.mesh
        self.params = params
        self.comm = mesh.comm

        self.W = compat.taylor_hood_space(mesh)
        self.V, vdofs = compat.collapse(self.W.sub(0))
        self.Q, pdofs = compat.collapse(self.W.sub(1))
        self.velocity_dofs = np.asarray(vdofs, dtype=np.int32)
        self.pressure_dofs = np.asarray(pdofs, dtype=np.int32)
        self.Vw = compat.vector_space(mesh, 1)

        self.solution = fem.Function(self.W, name="solution")   # (u^{n+1,k+1}, p^{n+1,k+1})
        self.iterate = fem.Function(self.W, name="iterate")     # (u^{n+1,k}, p^{n+1,k})
        self.u_old = fem.Function(self.V, name="u_old")         # uⁿ
        self.mesh_velocity = fem.Function(self.Vw, name="mesh_velocity")  # w
        self.dt = fem.Constant(mesh, compat.ScalarType(1e-3))

        size_local = self.W.dofmap.index_map.size_local * self.W.dofmap.index_map_bs
        self._owned_velocity = self.velocity_dofs[self.velocity_dofs < size_local]
        self._n_velocity = self.comm.allreduce(len(self._owned_velocity), op=MPI.SUM)
        self._size_local = size_local
        self._step_dt = None   # Δt of the step being solved

    # ------------------------------------------------------------------ time scheme
    #: ``time.scheme``: bdf1 (the forms use uⁿ and the motion's w) or bdf2 (``solvers.bdf``)
    scheme = "bdf1"
    #: ``time.error_norm``: the norm of the local error estimate over the velocity dofs
    error_norm = "rms"

    def _use_bdf2(self) -> None:
        """Second-order time scheme: the history (``models.stokes.history``), the effective
        old velocity û of the forms' "previous_velocity" and the motion's velocity u*."""
        self.scheme = "bdf2"
        self.history = TimeHistory(self._dof_positions())
        self.u_start = fem.Function(self.V, name="u_start")     # û = (α₁uⁿ − α₂u^{n−1})/α₀
        self.u_motion = fem.Function(self.V, name="u_motion")   # u* ≈ u(tⁿ + Δt/2)

    def _dof_positions(self) -> np.ndarray:
        """Positions of the mesh-velocity (P1) dofs on the current mesh, (n, 2)."""
        return self.Vw.tabulate_dof_coordinates()[:, :2]

    @property
    def previous_velocity_term(self):
        """The velocity of the forms' explicit half of the time derivative: uⁿ (BDF1) or û."""
        return self.u_start if self.scheme == "bdf2" else self.u_old

    @property
    def motion_source(self):
        """The velocity whose boundary motion the mesh follows: uⁿ (BDF1) or u*."""
        return self.u_motion if self.scheme == "bdf2" else self.u_old

    def prepare_motion(self, dt: float | None) -> bool:
        """u* = uⁿ + (r/2)(uⁿ − u^{n−1}) for a step ``dt`` (BDF2 only; None: uⁿ); whether
        the mesh motion is to be second order (BDF2 with a step and a history)."""
        if self.scheme != "bdf2":
            return False
        u = self.u_old.x.array
        self.u_motion.x.array[:] = u if dt is None else self.history.midpoint(u, dt)
        return dt is not None and self.history.previous_step is not None

    def set_step(self, dt: float) -> None:
        """Make the forms those of a step ``dt`` on the current (moved) mesh: BDF1's Δt, or
        BDF2 as BDF1 with Δt/α₀ and û, and the convection's mesh velocity
        w^{n+1} = (α₀x^{n+1} − α₁xⁿ + α₂x^{n−1})/Δt once x^{n−1} is known."""
        self._step_dt = dt
        if self.scheme != "bdf2":
            self.dt.value = dt
            return
        h = self.history
        self.dt.value = dt / h.coefficients(dt)[0]
        self.u_start.x.array[:] = h.effective_old(self.u_old.x.array, dt)
        w = h.mesh_velocity(self._dof_positions(), dt)
        if w is not None:
            self.mesh_velocity.x.array[:] = w.ravel()

    def local_error(self) -> float | None:
        """The estimated local error of the last solved step (BDF2 with two past steps) [m/s]
        in ``error_norm`` over the velocity dofs: rms, √(Σ eᵢ²/N), or max, maxᵢ |eᵢ|; None
        otherwise."""
        if self.scheme != "bdf2" or self._step_dt is None:
            return None
        new = self.solution.x.array[self.velocity_dofs]
        error = self.history.local_error(new, self.u_old.x.array, self._step_dt)
        if error is None:
            return None
        owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        if self.error_norm == "max":
            local = float(np.max(np.abs(error[:owned]))) if owned else 0.0
            return self.comm.allreduce(local, op=MPI.MAX)
        return self.rms(error[:owned])

    # ------------------------------------------------------------------ conditions
    def _make_system(self, a, L):
        """The linear system of (a, L) with the Dirichlet conditions (all zero); periodic when
        the scene has a periodic pair (the slave side carries the translation onto its master)."""
        bcs = self._dirichlet_bcs()
        slave = self.params.periodic_slave
        if slave is not None:
            from dpcollapse.solvers.periodic import periodic_system

            return periodic_system(a, L, bcs, self.W, self.tagged.facet_tags, slave.tag,
                                   slave.translation)
        return LinearSystem(a, L, bcs, homogeneous=True)   # zero_dirichlet only

    def _has_tag(self, tag: int) -> bool:
        local = bool(np.any(self.tagged.facet_tags.values == tag))
        return self.comm.allreduce(local, op=MPI.LOR)

    def _dirichlet_bcs(self):
        """On each solid side of the scene: no slip u = 0, or no penetration u·n = 0 exactly
        on a side parallel to an axis (the component along its normal: u_y = 0 on the bed
        y = 0, u_x = 0 on the wall x = 0). Slanted sides: ``weak_walls``."""
        velocity = self.W.sub(0)
        ft = self.tagged.facet_tags
        return [zero_dirichlet(velocity if b.kind == BoundaryKind.NO_SLIP else velocity.sub(b.axis),
                               ft, b.tag) for b in self.params.of_kind(*SOLID) if not b.slanted]

    def weak_walls(self) -> list[tuple[str, int]]:
        """(name, tag) of the slanted solid sides on this mesh, where u·n = 0 is imposed by
        Nitsche's method (``forms.no_penetration``)."""
        return [(f"{b.name}_no_penetration", b.tag) for b in self.params.of_kind(*SOLID)
                if b.slanted and self._has_tag(b.tag)]

    # ------------------------------------------------------------------ surface tension
    #: the P1 field γ of seed 000's local surface tension, None without it
    surface_gamma = None

    def _surface_tension(self, ds):
        """(γ, ds over the free surface) for the forms' "surface_tension" term when
        ``params.surface_tension`` γ̄0 > 0 (γ the P1 field ``surface_gamma``, set from the
        current surface by ``update_surface_tension``), else None (no term: the forms are
        those without it)."""
        self.surface_gamma = None
        tags = [b.tag for b in self.params.of_kind(BoundaryKind.FREE_SURFACE) if self._has_tag(b.tag)]
        if not (self.params.surface_tension > 0 and tags):
            return None
        self._surface_tags = tags
        self.surface_gamma = fem.Function(compat.scalar_space(self.mesh, 1), name="surface_tension")
        return self.surface_gamma, sum((ds(t) for t in tags[1:]), ds(tags[0]))

    def update_surface_tension(self) -> None:
        """γ_i = γ0_i C_i at the free-surface nodes of the current mesh (seed 000; see
        ``geometry.curvature``): explicit in the step, from the geometry of Ω^{n+1}."""
        if self.surface_gamma is None:
            return
        points, gamma = surface_tension_nodes(self.tagged, self._surface_tags,
                                              self.params.surface_tension,
                                              self.params.surface_tension_extent)
        set_nodal_values(self.surface_gamma, points, gamma)

    # ------------------------------------------------------------------ state access
    def set_velocity(self, profile) -> None:
        """Set uⁿ and the first iterate to ``profile(x) -> (2, n)`` (initial condition)."""
        self.u_old.interpolate(profile)
        self.iterate.x.array[self.velocity_dofs] = self.u_old.x.array
        self.solution.x.array[:] = self.iterate.x.array

    # ------------------------------------------------------------------ state access
    def velocity(self, which: fem.Function | None = None):
        return (which or self.solution).sub(0)

    def velocity_values(self, which: fem.Function | None = None) -> np.ndarray:
        """Owned velocity dof values (flat) of ``which`` (default: the solution)."""
        return (which or self.solution).x.array[self._owned_velocity]

    def rms(self, values: np.ndarray) -> float:
        total = self.comm.allreduce(float(np.dot(values, values)), op=MPI.SUM)
        return math.sqrt(total / max(self._n_velocity, 1))

    def accept_step(self) -> None:
        """uⁿ ← u^{n+1}: the solution becomes the old state and the first iterate (BDF2: uⁿ,
        Δt and the mesh enter the history)."""
        if self.scheme == "bdf2":
            self.history.push(self.u_old.x.array, self._step_dt, self._dof_positions())
        self.iterate.x.array[:] = self.solution.x.array
        self.u_old.x.array[:] = self.solution.x.array[self.velocity_dofs]

    #: the adaptive step's iteration thresholds are multiplied by this (``simulation``)
    iteration_scale = 1
    #: names of the per-cell fields the model exports (``cell_field``)
    exported_cell_fields: tuple[str, ...] = ()

    def cell_field(self, name: str) -> np.ndarray:
        """Values per local cell of the exported field ``name``."""
        raise KeyError(f"{type(self).__name__} exports no cell field {name!r}")

    def multiplier_functions(self) -> dict:
        """Fields besides (u, p) that a remesh or checkpoint must carry (none by default)."""
        return {}

    def copy_state_from(self, other: StokesState) -> None:
        """Take the state of a flow on the same mesh with the same dofs (new facet tags)."""
        for name in ("solution", "iterate", "u_old", "mesh_velocity"):
            getattr(self, name).x.array[:] = getattr(other, name).x.array
        if self.scheme == "bdf2" and other.scheme == "bdf2":
            self.history.copy_from(other.history)
            self._step_dt = other._step_dt

    def reset_iterate(self) -> None:
        """Start the next step's fixed point from the last accepted state."""
        self.solution.x.array[:] = self.iterate.x.array

    def destroy(self) -> None:
        """Free the PETSc objects of the linear system and solver."""
        self.system.destroy()
        self.solver.destroy()

    # ------------------------------------------------------------------ snapshot / transfer
    def snapshot(self) -> dict[str, CellwiseField]:
        """The accepted state as mesh-independent fields gathered on every rank: "velocity"
        uⁿ (P2), "pressure" pⁿ (P1), and the multipliers by name (what a remesh carries and
        a checkpoint stores)."""
        u, p = snapshot(self)
        return {"velocity": u, "pressure": p, **snapshot_multipliers(self)}

    def checkpoint_fields(self) -> dict[str, CellwiseField]:
        """``snapshot`` plus, under BDF2, the history of this mesh (``snapshot_history``):
        what a checkpoint stores (a remesh carries the snapshot only)."""
        fields = self.snapshot()
        if self.scheme == "bdf2":
            fields.update(snapshot_history(self))
        return fields

    def checkpoint_state(self) -> dict:
        """The numbers besides the fields (``checkpoint_fields``) that the next step reads,
        by checkpoint-state key: under BDF2 the history's (``TimeHistory.record``)."""
        return {HISTORY_KEY: self.history.record()} if self.scheme == "bdf2" else {}

    def restore_checkpoint(self, fields: dict[str, CellwiseField], state: dict) -> None:
        """The history of a checkpoint of this mesh (``checkpoint_fields``,
        ``checkpoint_state``; its keys are taken out of ``state``); without one (BDF1, or an
        older checkpoint) it stays empty."""
        record = state.pop(HISTORY_KEY, None)
        if self.scheme == "bdf2" and record is not None:
            load_history(self, fields, record)
        elif self.scheme == "bdf2":
            note_not_restored(state, "the BDF2 history (the first resumed steps are BDF1)")

    def transfer(self, fields: dict[str, CellwiseField]) -> float:
        """Set the state from ``snapshot`` fields of another mesh (evaluated at this mesh's
        dofs, extrapolated outside the old domain); the largest extrapolation distance [m].
        Multipliers this model does not carry are ignored; missing ones stay zero."""
        outside = load_state(self, fields["velocity"], fields["pressure"])
        load_multipliers(self, {k: v for k, v in fields.items() if k not in ("velocity", "pressure")})
        return outside


def _cellwise(V, values: np.ndarray, bs: int, degree: int) -> CellwiseField:
    mesh = V.mesh
    n = compat.num_owned_cells(mesh)
    dofs = compat.cell_dofs(V)[:n]
    coords = V.tabulate_dof_coordinates()[:, :2]
    verts = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n]]
    return CellwiseField(vertices=verts, points=coords[dofs],
                         values=values.reshape(-1, bs)[dofs], degree=degree)


def snapshot(flow) -> tuple[CellwiseField, CellwiseField]:
    """The accepted state (uⁿ on P2, pⁿ on P1) of ``flow`` gathered on every rank."""
    u = _cellwise(flow.V, flow.u_old.x.array, 2, 2)
    p = _cellwise(flow.Q, flow.iterate.x.array[flow.pressure_dofs], 1, 1)
    comm = flow.comm
    return concatenate(comm.allgather(u)), concatenate(comm.allgather(p))


def load_state(flow, u_field: CellwiseField, p_field: CellwiseField) -> float:
    """Set uⁿ, pⁿ (and the first iterate) of ``flow`` from snapshots; returns the largest
    distance of a new dof outside the old domain (extrapolated there)."""
    xu = flow.V.tabulate_dof_coordinates()[:, :2]
    flow.u_old.x.array[:] = u_field.evaluate(xu).ravel()
    outside = u_field.last_outside_distance
    xp = flow.Q.tabulate_dof_coordinates()[:, :2]
    flow.iterate.x.array[flow.pressure_dofs] = p_field.evaluate(xp)[:, 0]
    flow.iterate.x.array[flow.velocity_dofs] = flow.u_old.x.array
    flow.solution.x.array[:] = flow.iterate.x.array
    return flow.comm.allreduce(float(outside), op=MPI.MAX)


def snapshot_mixed(flow, values: np.ndarray, names: tuple[str, str]) -> dict[str, CellwiseField]:
    """A (u, p) dof array of ``flow.W`` (``values``, local with ghosts) as the fields
    ``names`` (P2 velocity, P1 pressure) gathered on every rank."""
    u = _cellwise(flow.V, values[flow.velocity_dofs], 2, 2)
    p = _cellwise(flow.Q, values[flow.pressure_dofs], 1, 1)
    comm = flow.comm
    return {names[0]: concatenate(comm.allgather(u)), names[1]: concatenate(comm.allgather(p))}


def load_mixed(flow, fields: dict[str, CellwiseField], names: tuple[str, str]) -> np.ndarray:
    """The (u, p) dof array of ``snapshot_mixed`` fields on ``flow``'s mesh (exact on the
    mesh they were taken on: evaluated at their own nodes)."""
    values = np.zeros_like(flow.iterate.x.array)
    values[flow.velocity_dofs] = fields[names[0]].evaluate(
        flow.V.tabulate_dof_coordinates()[:, :2]).ravel()
    values[flow.pressure_dofs] = fields[names[1]].evaluate(
        flow.Q.tabulate_dof_coordinates()[:, :2])[:, 0]
    return values


#: the checkpoint state's entry of the BDF2 history's numbers (``TimeHistory.record``)
HISTORY_KEY = "time_history"
#: Checkpoint names of the BDF2 history: u^{n−1}, u^{n−2} (P2) and x^{n−1} − xⁿ (P1)
HISTORY_VELOCITIES = ("history_velocity_1", "history_velocity_2")
HISTORY_DISPLACEMENT = "history_mesh_displacement"


def snapshot_history(flow) -> dict[str, CellwiseField]:
    """The BDF2 history of ``flow`` (``models.stokes.history``) gathered on every rank: the
    past velocities on P2 and the displacement x^{n−1} − xⁿ of the mesh-velocity (P1) dofs."""
    h, comm = flow.history, flow.comm
    fields = {name: concatenate(comm.allgather(_cellwise(flow.V, u, 2, 2)))
              for name, u in zip(HISTORY_VELOCITIES, h.velocities)}
    if len(h.positions) > 1:
        back = (h.positions[1] - h.positions[0]).ravel()
        fields[HISTORY_DISPLACEMENT] = concatenate(comm.allgather(_cellwise(flow.Vw, back, 2, 1)))
    return fields


def load_history(flow, fields: dict[str, CellwiseField], record: dict) -> None:
    """Set the BDF2 history of ``flow`` from ``snapshot_history`` fields of the same mesh
    and the history's ``record`` (exact to round-off: the fields are evaluated at their own
    nodes)."""
    xu = flow.V.tabulate_dof_coordinates()[:, :2]
    velocities = [fields[name].evaluate(xu).ravel() for name in HISTORY_VELOCITIES if name in fields]
    previous = None
    if HISTORY_DISPLACEMENT in fields:
        x = flow._dof_positions()
        previous = x + fields[HISTORY_DISPLACEMENT].evaluate(x)
    flow.history.restore(record, velocities, previous)


#: Discontinuous fields are located this fraction of the way from each dof towards its
#: cell's centroid, so that a dof on a shared vertex or edge takes its own cell's value
#: (exact on the same mesh: a checkpoint restores the multipliers as they were).
INSIDE_SHIFT = 1e-6


def _evaluation_points(V) -> np.ndarray:
    """Where to evaluate a snapshot for V's dofs: the dof coordinates, pulled slightly into
    their cell for discontinuous spaces (every local dof belongs to one local cell)."""
    x = V.tabulate_dof_coordinates()[:, :2].copy()
    if compat.element_info(V).family != "DG":
        return x
    mesh = V.mesh
    cells = compat.cell_dofs(V)
    centroids = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:len(cells), :3]].mean(axis=1)
    for j in range(cells.shape[1]):
        x[cells[:, j]] += INSIDE_SHIFT * (centroids - x[cells[:, j]])
    return x


def snapshot_multipliers(flow) -> dict[str, CellwiseField]:
    """The augmented Lagrangian multipliers of ``flow`` (none for other solvers), gathered on
    every rank: DG tensors (σ', γ̇) and P2 vectors (σ_T, δ, σ_w, δ_w), cell by cell."""
    fields = {}
    for name, func in flow.multiplier_functions().items():
        V = func.function_space
        bs = V.dofmap.index_map_bs
        degree = compat.element_info(V).degree
        fields[name] = concatenate(flow.comm.allgather(_cellwise(V, func.x.array, bs, degree)))
    return fields


def load_multipliers(flow, fields: dict[str, CellwiseField]) -> None:
    """Evaluate snapshots of multipliers at ``flow``'s dof coordinates (a warm start for the
    iteration: the converged step does not depend on it). Missing names are left at zero."""
    targets = flow.multiplier_functions()
    for name, field in fields.items():
        if name in targets:
            func = targets[name]
            V = func.function_space
            # the cell found from the point pulled inside, its polynomial at the dof itself
            # (on the same mesh: the node's stored value exactly, ``CellwiseField``)
            cells, _ = field.locate(_evaluation_points(V))
            func.x.array[:] = field.evaluate_in_cells(V.tabulate_dof_coordinates()[:, :2],
                                                      cells).ravel()


