"""ALE mesh motion: solve for the mesh velocity w, limit Δt, move the nodes by Δt·w.

The rigid bed under the mass is the scene's profile y = b(x) (``Scene.bed_height``: b = 0
for a flat bed; a step down at x_e: b = s for x < x_e, 0 beyond). A free-surface node of an
overturning nose that comes down on it lands there (its facets become bed facets); a bed
node that slides past the end of a higher bed (b(x) < y: it has left the plateau) takes
off, and a bed facet whose two nodes have taken off becomes free surface.
"""

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

    def __init__(self, flow, penalty: float, linear_solver: str = "mumps", bed_height=None,
                 conserve_area: bool = False):
        self.flow = flow
        #: y = b(x) of the rigid bed under the abscissae x (``Scene.bed_height``; None: y = 0)
        self.bed_height = bed_height or flat_bed
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
        # the bed nodes lie on the bed profile y = b(x) (not a rotated scene): free-surface
        # nodes stay above it
        xb = mesh.geometry.x[self._bed_nodes]
        on = bool(np.all(xb[:, 1] == self.bed_height(xb[:, 0])))
        self._on_profile = mesh.comm.allreduce(on, op=MPI.LAND) and mesh.comm.allreduce(
            len(self._bed_nodes), op=MPI.SUM) > 0
        # numerics.step_conserve_area: each move's area change put back (``ale.area``);
        # axisymmetric: the body's volume 2π∫ r dA
        axisymmetric = getattr(flow.params.coordinates, "name", "planar") == "axisymmetric"
        self.area_keeper = AreaKeeper(mesh, ft, surface, Vw, self._node_dof, gdm,
                                      axisymmetric=axisymmetric) if conserve_area else None

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

    def _bed_spans(self, x: np.ndarray) -> dict[float, tuple[float, float]]:
        """bed level b -> (smallest, largest) x of the bed nodes on it (global): the toe is
        the largest x on the level of the bed the mass started on."""
        xb = x[self._bed_nodes]
        levels = self.bed_height(xb[:, 0])
        comm = self.mesh.comm
        spans = {}
        for level in sorted(set().union(*comm.allgather(set(np.unique(levels).tolist())))):
            on = xb[levels == level, 0]
            lo = comm.allreduce(float(on.min()) if len(on) else np.inf, op=MPI.MIN)
            hi = comm.allreduce(float(on.max()) if len(on) else -np.inf, op=MPI.MAX)
            spans[level] = (lo, hi)
        return spans

    def _overhang(self, x: np.ndarray) -> np.ndarray:
        """Mask of free-surface nodes over no bed node of the bed level under them: an
        overturning front's nose ahead of the toe, or the underside of a mass falling from a
        higher bed onto a lower one where none of it has landed yet."""
        xs = x[self._surface_nodes]
        levels = self.bed_height(xs[:, 0])
        over = np.ones(len(xs), dtype=bool)
        for level, (lo, hi) in self._bed_spans(x).items():
            at = levels == level
            over[at] = (xs[at, 0] < lo) | (xs[at, 0] > hi)
        return over

    def max_step(self, dt: float, shrink: float = 0.5) -> float:
        """Largest step ≤ ``dt`` (global) such that every cell keeps ``shrink`` of its area,
        no free-surface node over the bed loses more than ``shrink`` of its height above the
        bed b(x), and no node of an overturning nose (over no bed node: ahead of the toe, or
        under a mass falling from a higher bed, ``_overhang``) goes below the bed: such a node lands
        exactly on it (seed 000: "limit the time step so that the free surface nodes do not
        cross the bottom"). A nose node that would land within ``LANDING_FRACTION``·dt does
        not shorten the step (no Zeno sequence of ever smaller steps): it reaches the bed
        during the step and ``move`` puts it there."""
        x = self.mesh.geometry.x[:, :2]
        vel = self.node_velocity()
        tau = min(dt, max_safe_step(x[self._cells], vel[self._cells], shrink))
        xs = x[self._surface_nodes]
        y = xs[:, 1] - self.bed_height(xs[:, 0])    # the height above the bed under the node
        vy = vel[self._surface_nodes, 1]
        ahead = self._overhang(x)
        falling = (vy < 0) & (y > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            limit = np.where(ahead, y, (1 - shrink) * y) / -vy
        constraining = falling & ~(ahead & (limit < LANDING_FRACTION * dt))
        if np.any(constraining):
            tau = min(tau, float(np.min(limit[constraining])))
        return self.mesh.comm.allreduce(tau, op=MPI.MIN)

    def move(self, dt: float) -> tuple[np.ndarray, int, int]:
        """x ← x + Δt·w. Nose nodes that reach the bed y = b(x) are put exactly on it (they
        arrive there by their own velocity; the correction is round-off). Returns the old
        coordinates (to undo the move), the global number of nodes that landed and of bed
        nodes that took off in this move (slid past the end of a higher bed: b(x) < y): their
        bed facets become free surface (``retag_bed``), the facet from the last node on the
        higher bed to the first past its end spans the edge (a chord: O(h) from the corner)."""
        x = self.mesh.geometry.x
        old = x.copy()
        ahead = self._overhang(x)
        x[:, :2] += dt * self.node_velocity()
        b = self.bed_height
        nodes = self._surface_nodes[ahead]
        scale = max(float(np.ptp(old[:, 0])), 1e-300)
        bed_new = b(x[nodes, 0])
        came_from_above = old[nodes, 1] > np.maximum(b(old[nodes, 0]), bed_new)
        landed = nodes[(x[nodes, 1] - bed_new <= LANDING_TOLERANCE * scale) & came_from_above]
        x[landed, 1] = b(x[landed, 0])
        # no free-surface node goes below the rigid bed: one already on it (landed, its
        # facets not yet retagged) is not held there by w·n = 0 nor seen by the step limit
        # (height 0); one behind the toe may overshoot through the mesh-velocity smoothing.
        # A node that went in under a higher bed sideways (through a step's face, from below
        # its top) is put back on the face instead (``_stop_at_face``).
        surface = self._surface_nodes if self._on_profile else self._surface_nodes[:0]
        bed_at = b(x[surface, 0])
        sideways = (bed_at > b(old[surface, 0])) & (old[surface, 1] < bed_at)
        below = surface[(x[surface, 1] < bed_at) & ~sideways]
        x[below, 1] = b(x[below, 0])
        landed = np.union1d(landed, below[old[below, 1] > b(old[below, 0])])
        bed = self._bed_nodes
        if self._on_profile:
            _stop_at_face(x, old, np.union1d(surface, bed), b)
        # off the bed: above it after the move (slid past a higher bed's end)
        took_off = bed[x[bed, 1] > b(x[bed, 0])] if self._on_profile else bed[:0]
        if self.area_keeper is not None:
            self.area_keeper.restore(self.area_keeper.area(old))
        comm = self.mesh.comm
        return old, comm.allreduce(len(landed), op=MPI.SUM), comm.allreduce(len(took_off), op=MPI.SUM)

    def destroy(self) -> None:
        self.system.destroy()
        self.solver.destroy()


def _tagged_nodes(mesh, facet_tags, tag: int) -> np.ndarray:
    facets = facet_tags.indices[facet_tags.values == tag]
    return np.unique(compat.entities_to_geometry(mesh, 1, facets).ravel())


#: Bisections of a node's move that find where it meets a step's face (2⁻³⁰ of the move).
FACE_BISECTIONS = 30


def _stop_at_face(x: np.ndarray, old: np.ndarray, nodes: np.ndarray, bed_height) -> None:
    """Boundary nodes that moved sideways into a higher bed (below b(x) now, at or above
    the bed under them before: through a step's face) are put back along their move to where
    they meet the face (bisection of the move to FACE_BISECTIONS halvings, on the side of the
    open lower bed): the face is a rigid wall that they then slide along."""
    b = bed_height
    inside = nodes[(x[nodes, 1] < b(x[nodes, 0])) & (old[nodes, 1] >= b(old[nodes, 0]))
                   & (b(x[nodes, 0]) > b(old[nodes, 0]))]
    if not len(inside):
        return
    start, end = old[inside, :2], x[inside, :2].copy()
    lo, hi = np.zeros(len(inside)), np.ones(len(inside))
    for _ in range(FACE_BISECTIONS):
        mid = 0.5 * (lo + hi)
        p = start + mid[:, None] * (end - start)
        into = p[:, 1] < b(p[:, 0])
        hi, lo = np.where(into, mid, hi), np.where(into, lo, mid)
    x[inside, :2] = start + lo[:, None] * (end - start)


def flat_bed(x: np.ndarray) -> np.ndarray:
    """b(x) = 0: the bed is the line y = 0."""
    return np.zeros_like(np.asarray(x, dtype=float))


def retag_bed(tagged, bed_height=flat_bed):
    """Free-surface facets lying on the bed y = b(x) (both nodes) become bed facets (a landed
    nose); a bed facet with a node above it (slid past the end of a higher bed) becomes free
    surface: every bed node stays on the profile."""
    from dpcollapse.geometry.mesher import TaggedMesh

    mesh, ft = tagged.mesh, tagged.facet_tags
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    x = mesh.geometry.x[nodes]                         # (facets, 2 nodes, 3)
    height = x[:, :, 1] - bed_height(x[:, :, 0])
    values = np.where((ft.values == SURFACE) & np.all(height == 0.0, axis=1), BED, ft.values)
    values = np.where((ft.values == BED) & np.any(height > 0.0, axis=1), SURFACE, values)
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
