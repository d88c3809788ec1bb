"""A fixed domain (the periodic layer): nothing limits the step, nothing moves."""

from __future__ import annotations

import math


class FixedDomain:
    moving = False

    def __init__(self):
        self.solves = 0

    def limit_step(self, disc, dt: float) -> float:
        return math.inf

    def recompute(self, disc, dt: float | None = None) -> None:
        pass

    def move(self, disc, dt: float) -> tuple[None, None, int]:
        return None, None, 0

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
