"""A domain moving with the material (ALE, seed 000): the mesh velocity w of
``ale.motion``, the step limit that keeps cells and the free surface valid, the node update
x ← x + Δt w, and the remesh criterion on the smallest cell angle.

Remesh when the smallest angle is below ``numerics.remesh_min_angle`` and at least
REMESH_COOLDOWN steps have passed since the last remesh; a remesh that could not reach the
threshold (a sharp boundary corner) lowers it to REMESH_DEGRADATION × the angle it left,
so that the same mesh is not rebuilt every REMESH_COOLDOWN steps. With surgery on
(``numerics.remesh_surgery``), a contact of the free surface with the bed or the mass
(``geometry.surgery``) also asks for a remesh (after the same cooldown), where the surgery
is done; the check of every step reuses the boundary's chaining while the mesh only moves
(``geometry.boundary_loops``).

Events (``loop.EventSource``): ``landings``, the free-surface nodes of the nose that came
down on the bed in accepted moves; ``surgeries`` and
``surgery_area_change`` [m²], the boundary surgeries of remeshes and their area change (each
one also listed in run.json's ``surgery_events``). Check of an accepted step (``check_step``): the energy
balance of a closed mass moving with the mesh.

No solve on a mesh that cannot carry one (issue 47): a mesh whose smallest angle is below
MIN_ANGLE_FLOOR (or with non-finite node coordinates) is remeshed at the next step whatever
the cool-down; a remesh that cannot lift it above the floor (the boundary itself is
degenerate: a film or a spike thinner than the cells) ends the run, MeshError (exit 4),
before the new mesh is used.

With ``numerics.mesh_tolerance`` (``size_control``: tolerance [m/s], smallest and largest
size [m]) every remesh meshes the inside to the size field of the current velocity's error
indicator (``ale.size_field``), and every ADAPT_CHECK_EVERY steps (after as many since the
last remesh) the indicator is evaluated: cells above its trigger that can still be refined
ask for a remesh ("indicator").
"""

from __future__ import annotations

import logging
import math

from dpcollapse import compat
from dpcollapse.ale.motion import quality, retag_bed
from dpcollapse.ale.remesh import boundary_contact
from dpcollapse.domain.region_remesh import remesh_regions
from dpcollapse.errors import MeshError
from dpcollapse.geometry.boundary_loops import BoundaryLoops

#: Energy guard: the kinetic energy may exceed the work of gravity by at most this fraction
#: before the run is declared numerically unstable.
ENERGY_TOLERANCE = 0.05
#: Largest area change a remesh may make by dropping boundary vertices, relative to the
#: initial area.
REMESH_AREA_TOLERANCE = 1e-6
#: ... and with ``numerics.remesh_conserve_area`` (the net change is put back): the vertex
#: dropping may then remove sub-cell features of the boundary up to this fraction of the
#: area (1.4e-6 m², 0.06 cell of 5 mm, on the a = 1.42 column). At 1e-6 the column's nose kept
#: sub-grain lips of zero pressure on which the fixed point stalled (issue 49,
#: docs/benchmarks/2026-12-07-moving-mesh-front-film.md).
REMESH_AREA_TOLERANCE_CONSERVED = 1e-4
#: Steps between two remeshes triggered by the angle criterion alone.
REMESH_COOLDOWN = 5
#: After a remesh that left an angle below the threshold, remesh again only when the
#: smallest angle has dropped below this fraction of the angle the remesh left.
REMESH_DEGRADATION = 0.9
#: The smallest cell angle [deg] a mesh may have and still be solved on. A triangle of
#: smallest angle θ has a stiffness condition number ~ 1/sin²θ (3 300 at 1°); the healthy
#: runs measured stay above it (the μ(I) ladder's thinnest toe: 1.7°), the degenerating
#: 40° μ(I) bed went 3.1° → 0.5° → 0.0° over three remeshes, the last one 267 251 cells
#: (from 1 536) on which MUMPS's symbolic analysis never returned.
MIN_ANGLE_FLOOR = 1.0
#: With numerics.mesh_tolerance: steps between two evaluations of the error indicator (and
#: since the last remesh before the first).
ADAPT_CHECK_EVERY = 50

log = logging.getLogger("dpcollapse")


class MovingDomain:
    moving = True
    counted_events = ("landings", "surgeries", "surgery_area_change")

    def __init__(self, remesh_min_angle: float, mesh_size: float,
                 surface_mesh_size: float | None = None, trim_thickness: float = 0.0,
                 conserve_area: bool = False, surgery: bool = False,
                 axisymmetric: bool = False, trim_face_slope: float | None = None,
                 trim_face_speed: float = math.inf,
                 size_control: tuple[float, float, float] | None = None):
        self.remesh_min_angle = remesh_min_angle
        #: the slope μ_r of the film trim's cut face (``domain.base.film_face_slope``; None:
        #: vertical), used while the thickness front moves slower than ``trim_face_speed`` =
        #: √(g δ) [m/s] (a deposit); a faster front (the collapse) is cut vertically
        self.trim_face_slope, self.trim_face_speed = trim_face_slope, trim_face_speed
        #: |dx_f/dt| [m/s] of the thickness front over the steps since the last remesh (inf
        #: until two steps are known), and those steps' first and last (t, x_f)
        self.front_speed = math.inf
        self._front_since: tuple[float, float] | None = None
        self._front_now: tuple[float, float] | None = None
        self._window_read = False   # the loop state's front_window read (a resumed run)
        #: numerics.mesh_tolerance [m/s], mesh_size_min, mesh_size_max [m]; None: uniform sizes
        self.size_control = size_control
        self._flow_of = None   # the mesh (tagged) the last needs_remesh saw, and its flow
        #: geometry.symmetry axisymmetric: a remesh puts back the body's volume, not the area
        self.axisymmetric = axisymmetric
        self.surgery = surgery
        #: the chained boundary of the current mesh, for the contact check of every step
        self._boundary_loops = BoundaryLoops()
        #: the surgeries done by remeshes (``geometry.surgery.Surgery``), not yet taken
        self.surgeries: list = []
        #: run.json's ``surgery_events``: one entry per surgery of this run segment
        self.surgery_events: list[dict] = []
        self._listed = 0       # entries of surgery_events already taken as events
        self.trim_thickness, self.conserve_area = trim_thickness, conserve_area
        self.mesh_size, self.surface_mesh_size = mesh_size, surface_mesh_size
        self.solves = 0
        self._landed = 0       # nose nodes landed in accepted moves, not yet taken
        self._attempt = 0      # ... and in the move not yet accepted

    def limit_step(self, disc, dt: float) -> float:
        """Solve for w from uⁿ; the largest safe step ≤ dt (``MeshMotion.max_step``). With
        time.scheme bdf2, w follows u* extrapolated to the middle of the step: when the limit
        cuts the step, w is solved again for the shorter step and the limit checked again."""
        self.recompute(disc, dt)
        limit = disc.motion.max_step(dt)
        if limit < dt and disc.flow.scheme == "bdf2":
            self.recompute(disc, limit)
            limit = disc.motion.max_step(limit)
        return limit

    def recompute(self, disc, dt: float | None = None) -> None:
        """Solve for w again (for a step ``dt``: the extrapolation of time.scheme bdf2)."""
        disc.motion.compute(dt)
        self.solves += 1

    def move(self, disc, dt: float):
        """x ← x + Δt w: (old coordinates, the mesh with the facets of front nodes that landed
        on the bed retagged as bed and those of bed nodes that slid past the end of a higher
        bed as free surface (``ale.motion.retag_bed``), or None)."""
        self._landed += self._attempt   # the previous move was kept (``undo`` not called)
        old_x, landed, took_off = disc.motion.move(dt)
        self._attempt = landed
        if landed:
            log.debug("%d nose node(s) landed on the bed", landed)
        if took_off:
            log.debug("%d bed node(s) past the end of a higher bed", took_off)
        changed = landed or took_off
        return old_x, (retag_bed(disc.tagged, disc.motion.bed_height) if changed else None)

    def undo(self, disc, old_x) -> None:
        disc.mesh.geometry.x[:] = old_x
        self._attempt = 0

    def take_events(self) -> dict[str, float]:
        """Since the last call: nose nodes that landed on the bed (``landings``), boundary
        surgeries (``surgeries``) and their area change [m²] (``surgery_area_change``)."""
        landed, self._landed, self._attempt = self._landed + self._attempt, 0, 0
        done, self.surgeries, self._listed = self.surgeries, [], len(self.surgery_events)
        return {"landings": landed, "surgeries": len(done),
                "surgery_area_change": float(sum(d.area_change for d in done))}

    def counters(self) -> dict:
        """run.json: the mesh-velocity solves (one factorization each) and the surgeries."""
        out = {"mesh_velocity_factorizations": self.solves}
        return out | ({"surgery_events": self.surgery_events} if self.surgery_events else {})

    def check_step(self, measures: dict, state) -> None:
        """Dissipative flow: KE(t) − KE(0) ≤ W(t), the work of gravity ρ∫f·x dx|₀ᵗ (the mesh
        moves with the material). The explicit ALE moves the mesh with the previous step's
        velocity, so the kinetic energy of step n−1 is compared with the work up to step n;
        a gain above (1 + ENERGY_TOLERANCE) W means a numerical instability (MeshError)."""
        st, m = state, measures
        self._read_window(st)
        self._track_front(st.t, m.get("thick_front"))
        st.front_window = None if self._front_since is None else \
            [*self._front_since, self.front_speed if math.isfinite(self.front_speed) else None]
        work = m["gravity_moment"] - st.gravity_moment0
        previous = st.kinetic_energy_previous
        gained = (st.kinetic_energy0 if previous is None else previous) - st.kinetic_energy0
        st.kinetic_energy_previous = m["kinetic_energy"]
        if gained > (1 + ENERGY_TOLERANCE) * max(work, 0.0) + 1e-9 * max(abs(st.gravity_moment0), 1.0):
            raise MeshError(
                f"numerically unstable at t = {st.t:.4f} s: the kinetic energy gained "
                f"({gained:.3g} J/m) exceeds the work of gravity ({work:.3g} J/m); min cell angle "
                f"{m['min_angle']:.2f}°: the mass is likely thinner than geometry.mesh_size = "
                f"{self.mesh_size:g} m somewhere — use a finer mesh or a shorter time.end_time")

    def _read_window(self, state) -> None:
        """Once, at the first step a run takes: the front window a checkpoint stored
        (``LoopState.front_window``), so that a resumed run continues the uninterrupted one's
        window (and its ``front_speed`` before that step's first remesh)."""
        if self._window_read:
            return
        self._window_read = True
        window = getattr(state, "front_window", None)
        if window:
            self._front_since = (float(window[0]), float(window[1]))
            self.front_speed = math.inf if window[2] is None else float(window[2])

    def _track_front(self, t: float, x_f: float | None) -> None:
        """The thickness front's speed over the steps since the last remesh (a window without
        the remesh's own jumps of x_f): ``front_speed``, for the film trim's cut face."""
        if x_f is None or not math.isfinite(x_f):
            return
        if self._front_since is None:
            self._front_since = (t, x_f)
        self._front_now = (t, x_f)
        (t0, x0), (t1, x1) = self._front_since, self._front_now
        if t1 > t0:
            self.front_speed = abs(x1 - x0) / (t1 - t0)

    def degenerate(self, disc) -> str | None:
        """Why the current mesh cannot carry a solve (smallest angle below
        MIN_ANGLE_FLOOR, non-finite nodes), or None."""
        return _below_floor(quality(disc.mesh)["min_angle"])

    def needs_remesh(self, disc, state) -> str | None:
        self._read_window(state)
        self._flow_of = (disc.tagged, disc.flow)
        q = quality(disc.mesh)
        if _below_floor(q["min_angle"]) and state.last_remesh_step != state.step:
            return f"min angle {q['min_angle']:.2f}° below the floor {MIN_ANGLE_FLOOR:g}°"
        since = state.step - state.last_remesh_step
        after = state.remesh_angle_after if state.remesh_angle_after is not None else math.inf
        threshold = min(self.remesh_min_angle, REMESH_DEGRADATION * after)
        if q["min_angle"] < threshold and since >= REMESH_COOLDOWN:
            return f"min angle {q['min_angle']:.1f}°"
        if self.surgery and since >= REMESH_COOLDOWN:
            contact = boundary_contact(disc.tagged, self.mesh_size, self._boundary_loops)
            if contact:
                return f"boundary {contact}"
        if (self.size_control is not None and since >= ADAPT_CHECK_EVERY
                and state.step % ADAPT_CHECK_EVERY == 0):
            from dpcollapse.ale.size_field import recovery_indicator, under_resolved

            tolerance, size_min, _ = self.size_control
            cells = under_resolved(recovery_indicator(disc.flow.snapshot()["velocity"]),
                                   tolerance, size_min)
            if cells:
                return f"indicator: {cells} cell(s) above the mesh tolerance"
        return None

    def _background(self, tagged):
        """The size field of the current velocity (``ale.size_field``) as the mesher's
        background arrays, or None (no size control, or no flow of this mesh seen)."""
        if self.size_control is None or self._flow_of is None or self._flow_of[0] is not tagged:
            return None
        from dpcollapse.ale.size_field import size_field

        field, ind = size_field(self._flow_of[1].snapshot()["velocity"], *self.size_control)
        log.info("size field: indicator max %.2e m/s (tolerance %.2e), sizes %.4g–%.4g m",
                 float(ind.eta.max()), self.size_control[0], float(field.sizes.min()),
                 float(field.sizes.max()))
        return field.triangles, field.sizes

    def remesh(self, tagged, area0: float):
        """A new mesh of the current boundary (``ale.remesh``; with several material regions
        ``domain.region_remesh``, which keeps their interface): (tagged mesh with its cell tags,
        number of boundary vertices kept). The front film thinner than ``trim_thickness`` is
        trimmed and the area put back with ``conserve_area`` (``ale.remesh.remesh_domain``).
        MeshError when the boundary is no longer one closed loop."""
        tolerance = REMESH_AREA_TOLERANCE_CONSERVED if self.conserve_area else REMESH_AREA_TOLERANCE
        slope = self.trim_face_slope if self.front_speed < self.trim_face_speed else None
        try:
            new, _, nverts = remesh_regions(tagged, self.mesh_size, self.surface_mesh_size,
                                            tolerance * area0, self.trim_thickness,
                                            self.conserve_area, self.surgery, self.surgeries,
                                            axisymmetric=self.axisymmetric,
                                            trim_face_slope=slope,
                                            background=self._background(tagged))
        except ValueError as exc:   # the boundary is no longer one closed loop
            raise MeshError(f"mesh degenerate: cannot remesh, {exc}") from exc
        reason = _below_floor(quality(new.mesh)["min_angle"])
        if reason:
            cells = new.mesh.comm.allreduce(compat.num_owned_cells(new.mesh))
            raise MeshError(f"mesh degenerated: the remesh of the current boundary left a {reason} "
                            f"({cells} cells): the boundary itself is "
                            "degenerate (a film or spike thinner than the cells); no solve is "
                            "attempted on it")
        return new, nverts

    def remeshed(self, disc, state) -> None:
        """Record the smallest angle the new mesh reached (``state.remesh_angle_after``);
        below ``remesh_min_angle`` (set by a sharp boundary corner) say so: the next remesh
        then waits until the angle drops below REMESH_DEGRADATION × it."""
        after = state.remesh_angle_after = quality(disc.mesh)["min_angle"]
        self._front_since = None     # the front's speed: over the steps of the new mesh
        state.front_window = None
        for done in self.surgeries[len(self.surgery_events) - self._listed:]:   # this remesh's
            event = {"t": state.t, "step": state.step, "remesh": state.remeshes,
                     "what": done.describe(), "area_change": done.area_change,
                     "relative_area_change": done.area_change / state.area0,
                     "closed_pockets": len(done.closed_pockets),
                     "closed_area": float(sum(done.closed_pockets)), "holes": len(done.holes)}
            if done.regions:      # two regions: each one's area before and its changes
                event["regions"] = done.regions
            self.surgery_events.append(event)
            log.info("surgery at t = %.4f s (remesh %d): %s (%+.2e of the initial area)",
                     state.t, state.remeshes, event["what"], event["relative_area_change"])
        if after < self.remesh_min_angle:
            log.warning("remesh %d: the new mesh's smallest angle is %.1f° (< %g°, set by the "
                        "boundary); the next remesh waits until it drops below %.1f°",
                        state.remeshes, after, self.remesh_min_angle, REMESH_DEGRADATION * after)


def _below_floor(min_angle: float) -> str | None:
    """The reason a mesh of smallest angle ``min_angle`` [deg] cannot be solved on, or None."""
    if not math.isfinite(min_angle):
        return "non-finite node coordinate"
    if min_angle < MIN_ANGLE_FLOOR:
        return f"smallest angle of {min_angle:.2f}° (< the floor {MIN_ANGLE_FLOOR:g}°)"
    return None
