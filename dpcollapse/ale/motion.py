"""ALE mesh motion: solve for the mesh velocity w, limit Δt, move the nodes by Δt·w."""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.ale.area import AreaKeeper
from dpcollapse.ale.quality import max_safe_step, min_angles, signed_areas
from dpcollapse.forms.mesh_velocity import mesh_velocity_forms
from dpcollapse.geometry.mesher import BED, SURFACE
from dpcollapse.scenes.base import SOLID, BoundaryKind
from dpcollapse.solvers.assembly import LinearSystem, zero_dirichlet
from dpcollapse.solvers.linear import DirectSolver


#: A nose node closer to landing than this fraction of the step lands within the step.
LANDING_FRACTION = 0.1
#: Heights below this fraction of the domain length count as on the bed.
LANDING_TOLERANCE = 1e-9


class MeshMotion:
    """Mesh velocity of ``forms.mesh_velocity`` on P1 and the node update x ← x + Δt w.

    The geometry is P1, so a P1 mesh velocity moves every node the P2 one would; it is
    ~4× cheaper to solve.
    """

    def __init__(self, flow, penalty: float, linear_solver: str = "mumps",
                 conserve_area: bool = False):
        self.flow = flow
        mesh = self.mesh = flow.mesh
        self.w = flow.mesh_velocity
        Vw = self.w.function_space
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=flow.tagged.facet_tags)
        surface = [b.tag for b in flow.params.of_kind(BoundaryKind.FREE_SURFACE)]
        ds_surface = sum((ds(tag) for tag in surface[1:]), ds(surface[0]))
        # the velocity the boundary follows: uⁿ, or the extrapolated u* of time.scheme bdf2
        source = flow.motion_source
        a, L = mesh_velocity_forms(ufl.TrialFunction(Vw), ufl.TestFunction(Vw), source,
                                   fem.Constant(mesh, compat.ScalarType(penalty)), ds_surface)
        self.system = LinearSystem(a, L, self._slip_bcs(Vw), homogeneous=True)
        self._slanted = self._slanted_sides(Vw)
        # the extension's matrix is symmetric positive definite: Cholesky
        self.solver = DirectSolver(mesh.comm, linear_solver, prefix="dpc_ale_",
                                   positive_definite=True)
        # geometry node -> dof of Vw (P1 on a P1 mesh: same local vertex order per cell)
        gdm = compat.geometry_dofmap(mesh)
        vdm = compat.cell_dofs(Vw)
        self._node_dof = np.empty(mesh.geometry.x.shape[0], dtype=np.int32)
        self._node_dof[gdm.ravel()] = vdm.ravel()
        self._cells = gdm
        ft = flow.tagged.facet_tags
        self._surface_nodes = _tagged_nodes(mesh, ft, SURFACE)
        self._bed_nodes = _tagged_nodes(mesh, ft, BED)
        # the bed is the line y = 0 (not a rotated scene): free-surface nodes stay above it
        flat = bool(np.all(mesh.geometry.x[self._bed_nodes, 1] == 0.0))
        self._flat_bed = mesh.comm.allreduce(flat, op=MPI.LAND) and mesh.comm.allreduce(
            len(self._bed_nodes), op=MPI.SUM) > 0
        # numerics.step_conserve_area: each move's area change put back (``ale.area``)
        self.area_keeper = AreaKeeper(mesh, ft, surface, Vw, self._node_dof, gdm) \
            if conserve_area else None

    def _slip_bcs(self, Vw):
        """w·n = 0 on every solid side parallel to an axis (w_y on the bed y = 0, w_x on the
        wall x = 0): nodes slide along it, also where the flow sticks (no slip)."""
        ft = self.flow.tagged.facet_tags
        return [zero_dirichlet(Vw.sub(b.axis), ft, b.tag)
                for b in self.flow.params.of_kind(*SOLID) if b.axis is not None]

    def _slanted_sides(self, Vw) -> list[tuple[np.ndarray, np.ndarray]]:
        """(nodes of Vw, unit normal n) of each slanted solid side: there w·n = 0 is made
        exact after the solve by removing the normal part, w ← w − (w·n) n."""
        ft = self.flow.tagged.facet_tags
        fdim = self.mesh.topology.dim - 1
        sides = []
        for b in self.flow.params.of_kind(*SOLID):
            if b.axis is None:
                nodes = fem.locate_dofs_topological(Vw, fdim, ft.indices[ft.values == b.tag])
                sides.append((np.asarray(nodes, dtype=np.int64), np.asarray(b.normal, dtype=float)))
        return sides

    def compute(self, dt: float | None = None) -> None:
        """Solve for w from the accepted velocity uⁿ on the current mesh. time.scheme bdf2
        (once the flow has a history): from u* ≈ u(tⁿ + Δt/2) for a step ``dt``, and by the
        explicit midpoint rule for the node trajectories ẋ = w(x, t) — w solved once on Ωⁿ,
        the nodes moved by Δt/2·w, w solved again there with the same u*, the nodes put back
        (the extension depends on the mesh through its normals and h: w on Ωⁿ alone would
        leave a first-order error)."""
        midpoint = bool(self.flow.prepare_motion(dt))
        self._solve()
        if midpoint:
            x = self.mesh.geometry.x
            start = x.copy()
            x[:, :2] += 0.5 * dt * self.node_velocity()
            try:
                self._solve()
            finally:
                x[:] = start

    def _solve(self) -> None:
        """w on the current node positions, w·n = 0 made exact on slanted solid sides."""
        self.solver.set_operator(self.system.assemble_matrix())
        try:
            self.solver.solve(self.system.assemble_vector(), compat.petsc_vec(self.w))
        except RuntimeError as exc:     # LU breakdown: the mesh has degenerated
            from dpcollapse.errors import MeshError

            raise MeshError(f"the mesh-velocity solve failed ({exc}): the mesh has "
                            "degenerated; a smaller time.dt or geometry.mesh_size, or a "
                            "larger numerics.remesh_min_angle (remesh sooner), may carry it "
                            "further") from None
        self.w.x.scatter_forward()
        if self._slanted:
            w = self.w.x.array.reshape(-1, 2)
            for nodes, n in self._slanted:
                w[nodes] -= np.outer(w[nodes] @ n, n)
            self.w.x.scatter_forward()

    def node_velocity(self) -> np.ndarray:
        """w at every geometry node, (num_nodes, 2)."""
        return self.w.x.array.reshape(-1, 2)[self._node_dof]

    def toe_position(self) -> float:
        """x of the toe: the furthest bed node (global)."""
        x = self.mesh.geometry.x
        local = float(x[self._bed_nodes, 0].max()) if len(self._bed_nodes) else -np.inf
        return self.mesh.comm.allreduce(local, op=MPI.MAX)

    def _overhang(self, x: np.ndarray) -> np.ndarray:
        """Mask of free-surface nodes ahead of the toe (an overturning front's nose)."""
        return x[self._surface_nodes, 0] > self.toe_position()

    def max_step(self, dt: float, shrink: float = 0.5) -> float:
        """Largest step ≤ ``dt`` (global) such that every cell keeps ``shrink`` of its area,
        no free-surface node behind the toe loses more than ``shrink`` of its height, and no
        node of an overturning nose (ahead of the toe) goes below the bed: such a node lands
        exactly on it (seed 000: "limit the time step so that the free surface nodes do not
        cross the bottom"). A nose node that would land within ``LANDING_FRACTION``·dt does
        not shorten the step (no Zeno sequence of ever smaller steps): it reaches the bed
        during the step and ``move`` puts it there."""
        x = self.mesh.geometry.x[:, :2]
        vel = self.node_velocity()
        tau = min(dt, max_safe_step(x[self._cells], vel[self._cells], shrink))
        y = x[self._surface_nodes, 1]
        vy = vel[self._surface_nodes, 1]
        ahead = self._overhang(x)
        falling = (vy < 0) & (y > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            limit = np.where(ahead, y, (1 - shrink) * y) / -vy
        constraining = falling & ~(ahead & (limit < LANDING_FRACTION * dt))
        if np.any(constraining):
            tau = min(tau, float(np.min(limit[constraining])))
        return self.mesh.comm.allreduce(tau, op=MPI.MIN)

    def move(self, dt: float) -> tuple[np.ndarray, int]:
        """x ← x + Δt·w. Nose nodes that reach the bed are put exactly on it (they
        arrive there by their own velocity; the correction is round-off). Returns the old
        coordinates (to undo the move) and the global number of nodes that landed."""
        x = self.mesh.geometry.x
        old = x.copy()
        ahead = self._overhang(x)
        x[:, :2] += dt * self.node_velocity()
        nodes = self._surface_nodes[ahead]
        scale = max(float(np.ptp(old[:, 0])), 1e-300)
        landed = nodes[(x[nodes, 1] <= LANDING_TOLERANCE * scale) & (old[nodes, 1] > 0)]
        x[landed, 1] = 0.0
        # no free-surface node goes below the rigid bed: one already on it (landed, its
        # facets not yet retagged) is not held there by w·n = 0 nor seen by the step limit
        # (height 0); one behind the toe may overshoot through the mesh-velocity smoothing
        surface = self._surface_nodes if self._flat_bed else self._surface_nodes[:0]
        below = surface[x[surface, 1] < 0.0]
        x[below, 1] = 0.0
        landed = np.union1d(landed, below[old[below, 1] > 0])
        if self.area_keeper is not None:
            self.area_keeper.restore(self.area_keeper.area(old))
        return old, self.mesh.comm.allreduce(len(landed), op=MPI.SUM)

    def destroy(self) -> None:
        self.system.destroy()
        self.solver.destroy()


def _tagged_nodes(mesh, facet_tags, tag: int) -> np.ndarray:
    facets = facet_tags.indices[facet_tags.values == tag]
    return np.unique(compat.entities_to_geometry(mesh, 1, facets).ravel())


def retag_landed(tagged):
    """Free-surface facets lying on the bed (both nodes at y = 0) become bed facets."""
    from dpcollapse.geometry.mesher import TaggedMesh

    mesh, ft = tagged.mesh, tagged.facet_tags
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    on_bed = np.all(mesh.geometry.x[nodes, 1] == 0.0, axis=1)
    values = np.where((ft.values == SURFACE) & on_bed, BED, ft.values)
    return TaggedMesh(mesh, compat.meshtags(mesh, 1, ft.indices, values), tagged.cell_tags)


def cell_orientation(mesh) -> np.ndarray:
    """Sign of det J of each owned cell as built (gmsh cells are counter-clockwise, those
    of ``create_rectangle`` are not all): inversion is a change of this sign."""
    n = compat.num_owned_cells(mesh)
    return np.sign(signed_areas(mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n]]))


def quality(mesh, orientation: np.ndarray | None = None) -> dict:
    """Global minimum det J (relative to each cell's initial orientation: negative means
    inverted) and minimum angle [deg] of the owned cells."""
    n = compat.num_owned_cells(mesh)
    tri = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n]]
    det = signed_areas(tri) * (1.0 if orientation is None else orientation)
    ang = min_angles(tri)
    comm = mesh.comm
    return {
        "min_detJ": comm.allreduce(float(det.min()) if n else np.inf, op=MPI.MIN),
        "min_angle": comm.allreduce(float(ang.min()) if n else 180.0, op=MPI.MIN),
    }
