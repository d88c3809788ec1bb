"""A fixed domain (the periodic layer): nothing limits the step, nothing moves."""

from __future__ import annotations

import math


class FixedDomain:
    moving = False
    counted_events: tuple[str, ...] = ()

    def __init__(self):
        self.solves = 0

    def limit_step(self, disc, dt: float) -> float:
        return math.inf

    def recompute(self, disc, dt: float | None = None) -> None:
        pass

    def move(self, disc, dt: float) -> tuple[None, None]:
        return None, None

    def take_events(self) -> dict[str, int]:
        return {}

    def check_step(self, measures: dict, state) -> None:
        """No check: the material may leave or enter a fixed box (no closed-mass balance)."""

    def counters(self) -> dict[str, int]:
        """No mesh velocity: none solved (run.json's entry, as for a moving domain)."""
        return {"mesh_velocity_factorizations": self.solves}

    def undo(self, disc, token) -> None:
        pass

    def needs_remesh(self, disc, state) -> None:
        return None

    def degenerate(self, disc) -> None:
        return None

    def remesh(self, tagged, area0: float):
        raise NotImplementedError("a fixed domain is never remeshed")

    def remeshed(self, disc, state) -> None:
        pass
