"""What the time loop asks of a domain, fixed or moving (``Domain``), and which one a
config has (``make_domain``)."""

from __future__ import annotations

import math
from typing import Protocol


class Domain(Protocol):
    """limit Δt, move, undo, remesh; ``moving`` says whether the mesh follows the material
    (then the energy balance of a closed mass applies: ``check_step``). Its named events
    (``counted_events``, ``take_events``) are those of ``loop.EventSource``."""

    moving: bool
    #: mesh-velocity solves so far
    solves: int
    #: the events it reports (the moving domain: ``landings``)
    counted_events: tuple[str, ...]

    def take_events(self) -> dict[str, int]:
        """Counts of its events since the last call, of accepted moves only."""

    def check_step(self, measures: dict, state) -> None:
        """Its check of an accepted step from the model's ``measures`` and the ``loop.LoopState``
        (the moving domain: the energy balance); MeshError when it fails."""

    def counters(self) -> dict[str, int]:
        """Its run.json entries (the moving domain: ``mesh_velocity_factorizations``)."""

    def limit_step(self, disc, dt: float) -> float:
        """The largest step ≤ ``dt`` the domain allows from the accepted state (inf: none)."""

    def recompute(self, disc, dt: float | None = None) -> None:
        """Redo what ``limit_step`` prepared, for a retried (shorter) step."""

    def move(self, disc, dt: float) -> tuple[object, object]:
        """Move the mesh over ``dt``: (what ``undo`` needs, the mesh with new facet tags when
        the move changed a boundary's extent (the moving domain: front nodes that landed on
        the bed) else None)."""

    def undo(self, disc, token) -> None:
        """Take back ``move`` (and the events it would have reported)."""

    def needs_remesh(self, disc, state) -> str | None:
        """Why the mesh must be rebuilt now, or None."""

    def degenerate(self, disc) -> str | None:
        """Why the current mesh cannot carry a solve (the moving domain: a smallest angle
        below its floor), or None."""

    def remesh(self, tagged, area0: float):
        """A new mesh of the current boundary: (tagged mesh, boundary vertices)."""

    def remeshed(self, disc, state) -> None:
        """After a remesh onto ``disc``: the domain's own checks and state (the moving
        domain: the angle the new mesh reached, for the next remesh criterion)."""


def make_domain(cfg) -> Domain:
    """MovingDomain with ``numerics.ale``, else FixedDomain."""
    if cfg.numerics.ale:
        from dpcollapse.domain.moving import MovingDomain

        n = cfg.numerics
        return MovingDomain(n.remesh_min_angle, cfg.geometry.mesh_size,
                            cfg.geometry.surface_mesh_size, film_trim_thickness(cfg),
                            n.remesh_conserve_area, n.remesh_surgery,
                            axisymmetric=cfg.geometry.coordinates == "axisymmetric",
                            trim_face_slope=film_face_slope(cfg),
                            trim_face_speed=film_face_speed(cfg),
                            size_control=getattr(cfg, "size_control", None))
    from dpcollapse.domain.fixed import FixedDomain

    return FixedDomain()


def film_trim_thickness(cfg) -> float:
    """The front film thinner than this [m] is cut at remeshes: the larger of
    ``numerics.remesh_film_trim`` × ΔX and (μ(I)) ``numerics.remesh_film_trim_grains`` × d."""
    n = cfg.numerics
    grains = n.remesh_film_trim_grains * getattr(cfg.material, "grain_diameter", 0.0)
    return max(n.remesh_film_trim * cfg.geometry.mesh_size, grains)


def film_face_slope(cfg) -> float | None:
    """The slope μ_r of the film trim's cut face (``numerics.remesh_film_trim_face``): with
    ``repose``, μ_r = min(μ_s, μ_b), the material's friction tan(material.friction_angle) and,
    on a Coulomb bed, the bed's tan(boundary.bed_friction_angle) where it is lower (a face at
    that slope is at the yield of both; ``geometry.film_face``); None (a vertical cut) with
    ``vertical`` or where μ_r = 0 (no angle of repose)."""
    if cfg.numerics.remesh_film_trim_face != "repose":
        return None
    slope = cfg.material.mu_s
    if cfg.boundary.bed_condition == "coulomb":
        slope = min(slope, cfg.boundary.mu_bed)
    return slope if slope > 0 else None


def film_face_speed(cfg) -> float:
    """√(g δ) [m/s], δ the film trim's thickness (``film_trim_thickness``): the speed at which
    a face δ high slumps. A thickness front slower than this (``MovingDomain.front_speed``)
    is not carried by the collapse (a deposit: its film is cut at the angle of repose,
    ``film_face_slope``); a faster one is the flowing front, cut vertically."""
    return math.sqrt(cfg.material.gravity * film_trim_thickness(cfg))


def refuse_degenerate(domain: Domain, disc, t: float, dt: float, message: str) -> None:
    """A step that failed down to time.dt_min (at time ``t``, last try ``dt``, the solver's
    ``message``) on a mesh that cannot carry a solve (``domain.degenerate``) is the mesh's
    failure: MeshError (exit 4), not the solver's ConvergenceError (exit 3)."""
    reason = domain.degenerate(disc)
    if reason:
        from dpcollapse.errors import MeshError

        raise MeshError(f"mesh degenerated at t = {t:.4f} s: no convergence even with dt = "
                        f"{dt:.1e} s ({message}) on a mesh with a {reason}")
