"""Error-controlled step size: a PI controller (Gustafsson; Hairer & Wanner, II.4).

With e_n the local error estimate of step n (``solvers.bdf``, RMS over the velocity dofs
[m/s]), tol the tolerance and k = p + 1 = 3 for the second-order scheme, step n is
accepted when e_n ≤ tol and the next step is

    Δt_{n+1} = Δt_n · min(GROW, max(SHRINK, SAFETY (tol/e_n)^{α} (e_{n−1}/tol)^{β})),
    α = 0.7/k,  β = 0.4/k,

(without a previous estimate β = 0). A rejected step is retried with
Δt_n · max(SHRINK, SAFETY (tol/e_n)^{1/k}). GROW = 2 keeps the step ratio below the
zero-stability bound 1 + √2 of variable-step BDF2.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Safety factor on the predicted optimal step.
SAFETY = 0.9
#: Largest and smallest ratio of successive steps.
GROW = 2.0
SHRINK = 0.2
#: k = p + 1 for a second-order scheme.
ORDER = 3


@dataclass
class StepController:
    """PI step-size controller on a local error estimate; counts rejected steps."""

    tolerance: float
    previous_error: float | None = None
    rejected: int = 0

    def accept(self, error: float) -> bool:
        """Whether a step of local error ``error`` is accepted (counts a rejection)."""
        ok = error <= self.tolerance
        if not ok:
            self.rejected += 1
        return ok

    def next_step(self, dt: float, error: float | None) -> float:
        """The next step after an accepted step ``dt`` of local error ``error`` (None: no
        estimate yet, the step is kept)."""
        if error is None:
            return dt
        error = max(error, 1e-12 * self.tolerance)
        factor = SAFETY * (self.tolerance / error) ** (0.7 / ORDER)
        if self.previous_error is not None:
            factor *= (self.previous_error / self.tolerance) ** (0.4 / ORDER)
        self.previous_error = error
        return dt * min(GROW, max(SHRINK, factor))

    def retry_step(self, dt: float, error: float) -> float:
        """The step to retry after a rejection of step ``dt`` with local error ``error``."""
        return dt * max(SHRINK, min(0.9, SAFETY * (self.tolerance / error) ** (1.0 / ORDER)))

    def record(self) -> dict:
        """Its state for a checkpoint (JSON): the last estimate and the rejections so far."""
        return {"previous_error": self.previous_error, "rejected": self.rejected}

    def restore(self, record: dict) -> None:
        """The state of a checkpoint (``record``): a resumed run steps as the uninterrupted one."""
        self.previous_error = record["previous_error"]
        self.rejected = int(record["rejected"])

    def forget(self) -> None:
        """Drop the previous estimate (the history was lost: remesh)."""
        self.previous_error = None


def fit_to_end(step: float, remaining: float, dt_min: float, slack: float = 1e-12) -> float:
    """The step to take toward an end time ``remaining`` [s] away, aiming at ``step`` [s], so
    that no sliver shorter than ``dt_min`` is left before the end (issue 47: a last step of
    a few ns looked like a degenerate mesh):

    - ``remaining ≤ step``: the rest, in one step;
    - ``remaining − step < dt_min`` (a sliver would be left): split the rest in two equal
      steps, each ≥ dt_min and ≤ step, when ``remaining ≥ 2·dt_min``; else (the rest is
      under two smallest steps) the rest in one step, longer than ``step`` by < dt_min;
    - else ``step`` (also when the rest exceeds it by at most ``slack``, the time loop's own
      end tolerance: rounding, not a sliver — a fixed step that lands on the end in floating
      point keeps its steps).
    """
    if remaining <= step:
        return remaining
    if remaining - step <= slack:
        return step
    if remaining - step < dt_min:
        return remaining / 2 if remaining >= 2 * dt_min else remaining
    return step


class ToleranceUnreachable:
    """Counts consecutive steps taken at dt_min whose local error exceeds the tolerance
    (accepted, since no shorter step is allowed). After ``limit`` of them in a row the
    tolerance cannot be met: ``record`` returns True (issue 47: time.tolerance = 1e-12
    took 7 002 steps at dt_min without a word)."""

    def __init__(self, limit: int):
        self.limit = limit
        self.count = 0

    def record(self, forced: bool) -> bool:
        """``forced``: this step was accepted at dt_min above the tolerance."""
        self.count = self.count + 1 if forced else 0
        return self.count >= self.limit

    def check(self, dt: float, error: float | None, tolerance: float, dt_min: float,
              t: float) -> None:
        """Count an accepted step ``dt`` [s] of local error ``error`` [m/s]; ConvergenceError
        (exit 3) once ``limit`` steps in a row were at ``dt_min`` above ``tolerance``."""
        from dpcollapse.errors import ConvergenceError

        forced = error is not None and error > tolerance and dt <= dt_min * (1 + 1e-9)
        if self.record(forced):
            raise ConvergenceError(
                f"time.tolerance = {tolerance:g} cannot be met at t = {t:.4f} s: the local "
                f"error stayed above it for {self.count} steps in a row at time.dt_min = "
                f"{dt_min:g} s (last {error:.2e} m/s); use a larger time.tolerance or a smaller "
                "time.dt_min")
