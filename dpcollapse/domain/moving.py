"""A domain moving with the material (ALE, seed 000): the mesh velocity w of
``ale.motion``, the step limit that keeps cells and the free surface valid, the node update
x ← x + Δt w, and the remesh criterion on the smallest cell angle.

Remesh when the smallest angle is below ``numerics.remesh_min_angle`` and at least
REMESH_COOLDOWN steps have passed since the last remesh; a remesh that could not reach the
threshold (a sharp boundary corner) lowers it to REMESH_DEGRADATION × the angle it left,
so that the same mesh is not rebuilt every REMESH_COOLDOWN steps. With surgery on
(``numerics.remesh_surgery``), a contact of the free surface with the bed or the mass
(``geometry.surgery``) also asks for a remesh (after the same cooldown), where the surgery
is done; ``surgeries`` lists the ones done (``geometry.surgery.Surgery``), for the loop.
"""

from __future__ import annotations

import logging
import math

from dpcollapse.ale.motion import quality, retag_landed
from dpcollapse.ale.remesh import boundary_contact
from dpcollapse.domain.region_remesh import remesh_regions
from dpcollapse.errors import MeshError

#: Largest area change a remesh may make by dropping boundary vertices, relative to the
#: initial area.
REMESH_AREA_TOLERANCE = 1e-6
#: Steps between two remeshes triggered by the angle criterion alone.
REMESH_COOLDOWN = 5
#: After a remesh that left an angle below the threshold, remesh again only when the
#: smallest angle has dropped below this fraction of the angle the remesh left.
REMESH_DEGRADATION = 0.9

log = logging.getLogger("dpcollapse")


class MovingDomain:
    moving = True

    def __init__(self, remesh_min_angle: float, mesh_size: float,
                 surface_mesh_size: float | None = None, trim_thickness: float = 0.0,
                 conserve_area: bool = False, surgery: bool = False):
        self.remesh_min_angle = remesh_min_angle
        self.surgery = surgery
        #: the surgeries done by remeshes, not yet collected by the loop (``take_surgeries``)
        self.surgeries: list = []
        self.trim_thickness, self.conserve_area = trim_thickness, conserve_area
        self.mesh_size, self.surface_mesh_size = mesh_size, surface_mesh_size
        self.solves = 0

    def limit_step(self, disc, dt: float) -> float:
        """Solve for w from uⁿ; the largest safe step ≤ dt (``MeshMotion.max_step``). With
        time.scheme bdf2, w follows u* extrapolated to the middle of the step: when the limit
        cuts the step, w is solved again for the shorter step and the limit checked again."""
        self.recompute(disc, dt)
        limit = disc.motion.max_step(dt)
        if limit < dt and getattr(disc.flow, "scheme", "bdf1") == "bdf2":
            self.recompute(disc, limit)
            limit = disc.motion.max_step(limit)
        return limit

    def recompute(self, disc, dt: float | None = None) -> None:
        """Solve for w again (for a step ``dt``: the extrapolation of time.scheme bdf2)."""
        disc.motion.compute(dt)
        self.solves += 1

    def move(self, disc, dt: float):
        """x ← x + Δt w: (old coordinates, the mesh with the facets of front nodes that landed
        on the bed retagged as bed (``ale.motion.retag_landed``) or None, nodes landed)."""
        old_x, landed = disc.motion.move(dt)
        return old_x, (retag_landed(disc.tagged) if landed else None), landed

    def undo(self, disc, old_x) -> None:
        disc.mesh.geometry.x[:] = old_x

    def needs_remesh(self, disc, state) -> str | None:
        q = quality(disc.mesh)
        since = state.step - state.last_remesh_step
        after = state.remesh_angle_after if state.remesh_angle_after is not None else math.inf
        threshold = min(self.remesh_min_angle, REMESH_DEGRADATION * after)
        if q["min_angle"] < threshold and since >= REMESH_COOLDOWN:
            return f"min angle {q['min_angle']:.1f}°"
        if self.surgery and since >= REMESH_COOLDOWN and _one_region(disc.tagged):
            contact = boundary_contact(disc.tagged, self.mesh_size)
            if contact:
                return f"boundary {contact}"
        return None

    def take_surgeries(self) -> list:
        """The surgeries done since the last call (``geometry.surgery.Surgery``)."""
        done, self.surgeries = self.surgeries, []
        return done

    def remesh(self, tagged, area0: float):
        """A new mesh of the current boundary (``ale.remesh``; with several material regions
        ``domain.region_remesh``, which keeps their interface): (tagged mesh with its cell tags,
        number of boundary vertices kept). The front film thinner than ``trim_thickness`` is
        trimmed and the area put back with ``conserve_area`` (``ale.remesh.remesh_domain``).
        MeshError when the boundary is no longer one closed loop."""
        try:
            new, _, nverts = remesh_regions(tagged, self.mesh_size, self.surface_mesh_size,
                                            REMESH_AREA_TOLERANCE * area0, self.trim_thickness,
                                            self.conserve_area, self.surgery, self.surgeries)
        except ValueError as exc:   # the boundary is no longer one closed loop
            raise MeshError(f"mesh degenerate: cannot remesh, {exc}") from exc
        return new, nverts

    def remeshed(self, disc, state) -> None:
        """Record the smallest angle the new mesh reached (``state.remesh_angle_after``);
        below ``remesh_min_angle`` (set by a sharp boundary corner) say so: the next remesh
        then waits until the angle drops below REMESH_DEGRADATION × it."""
        after = state.remesh_angle_after = quality(disc.mesh)["min_angle"]
        if after < self.remesh_min_angle:
            log.warning("remesh %d: the new mesh's smallest angle is %.1f° (< %g°, set by the "
                        "boundary); the next remesh waits until it drops below %.1f°",
                        state.remeshes, after, self.remesh_min_angle, REMESH_DEGRADATION * after)


def _one_region(tagged) -> bool:
    """Whether the mesh's cells are of one material region (the surgery's domain; several
    regions are remeshed along their interface, ``domain.region_remesh``, without it)."""
    from mpi4py import MPI

    if tagged.cell_tags is None:
        return True
    values = tagged.cell_tags.values
    lo = tagged.mesh.comm.allreduce(int(values.min()) if len(values) else 2**31, op=MPI.MIN)
    hi = tagged.mesh.comm.allreduce(int(values.max()) if len(values) else -2**31, op=MPI.MAX)
    return lo >= hi
