"""The time loop's step size (``StepSize``), for any model.

Each step first tries Δt = min(target, time left, with ``time.adaptive`` the Courant bound
max(cfl/rate, dt_min), rate = max|uⁿ|/h or the model's equivalent); the loop then cuts it to
the domain's and the model's limits. After an accepted step the next target is:
- fixed ``time.dt``: a step cut by a failure, the domain or the end time (not by the
  model's own limit) restarts from min(dt, 2Δt) and recovers ×1.5 per step;
- ``time.adaptive``: ×STEP_GROWTH after a fixed point of ≤ FEW_ITERATIONS iterations,
  ×STEP_SHRINK after > MANY_ITERATIONS, else unchanged (the thresholds times the model's
  ``iteration_scale``), within [dt_min, dt_max];
- ``time.tolerance`` (``time.scheme: bdf2``): the PI controller of ``solvers.step_control``
  from the model's local error estimate; a step whose estimate exceeds the tolerance is
  undone and retried shorter (``retry``), and counted in run.json's ``rejected_steps``.
"""

from __future__ import annotations

import logging

from dpcollapse.solvers.step_control import StepController, ToleranceUnreachable, fit_to_end

log = logging.getLogger("dpcollapse")

#: Adaptive stepping: growth factor of the step after an easy fixed point, ...
STEP_GROWTH = 1.2
#: ... i.e. one of at most this many iterations; ...
FEW_ITERATIONS = 3
#: ... and the shrink factor after a fixed point of more than this many iterations.
STEP_SHRINK = 0.7
MANY_ITERATIONS = 12
#: time.tolerance: consecutive steps at time.dt_min above the tolerance before the run ends
#: (exit 3): the controller reaches dt_min within a few rejections (×0.2 each), so 20 steps
#: there mean the tolerance is out of reach, not a transient.
TOLERANCE_PATIENCE = 20


class StepSize:
    """The step rules of the ``time`` section (``cfg.time``); ``controller`` is the
    error-controlled step's (``time.tolerance``), else None."""

    def __init__(self, time_cfg, controller_record: dict | None = None):
        self.time = time_cfg
        self.controller = StepController(time_cfg.tolerance) if time_cfg.tolerance else None
        if self.controller is not None and controller_record is not None:
            self.controller.restore(controller_record)   # resumed
        self.error = None   # the local error estimate of the accepted step
        self.unreachable = ToleranceUnreachable(TOLERANCE_PATIENCE)   # steps at dt_min above it

    @property
    def rejected(self) -> int:
        """Steps undone because their error estimate exceeded ``time.tolerance``."""
        return self.controller.rejected if self.controller else 0

    def first_try(self, target: float, time_left: float, rate: float) -> float:
        """The step to try before the domain's and the model's limits [s]."""
        self.error = None
        dt = fit_to_end(target, time_left, self.time.dt_min)   # no sliver left before the end
        if self.time.adaptive and rate > 0:
            dt = min(dt, max(self.time.cfl / rate, self.time.dt_min))
        return dt

    def retry(self, dt: float, flow, t: float) -> float | None:
        """After a converged attempt of ``dt``: the shorter step to retry it with when its
        local error (``flow.local_error()``) is rejected, else None (accepted)."""
        if self.controller is None:
            return None
        error = self.error = flow.local_error()
        if error is None or dt <= self.time.dt_min or self.controller.accept(error):
            return None
        retry = max(self.controller.retry_step(dt, error), self.time.dt_min)
        log.debug("t = %.4f s: step %.2e s rejected (local error %.2e m/s > %.2e); retried "
                  "with %.2e s", t, dt, error, self.time.tolerance, retry)
        return retry

    def check_reachable(self, dt: float, t: float) -> None:
        """ConvergenceError (exit 3) once TOLERANCE_PATIENCE steps in a row were accepted at
        time.dt_min with a local error above time.tolerance: the tolerance cannot be met."""
        if self.controller is None:
            return
        self.unreachable.check(dt, self.error, self.time.tolerance, self.time.dt_min, t)

    def next_target(self, dt: float, target: float, iterations: int, scale: float,
                    model_limit: float) -> float:
        """The target of the next step after an accepted ``dt`` (the target it was tried
        with, the fixed point's ``iterations``, the model's ``iteration_scale`` and step
        limit)."""
        t = self.time
        if t.adaptive:
            # an augmented Lagrangian iteration is one back-substitution, not a
            # factorization: measured 3 ms against 15 ms per Picard iteration (2 cm collapse)
            if iterations <= FEW_ITERATIONS * scale:
                dt *= STEP_GROWTH
            elif iterations > MANY_ITERATIONS * scale:
                dt *= STEP_SHRINK
            return min(max(dt, t.dt_min), t.dt_max)
        if self.controller is not None:
            return min(max(self.controller.next_step(dt, self.error), t.dt_min), t.dt_max)
        cut = dt < min(target, model_limit)   # by a failure, the domain or end_time
        target = min(t.dt, 2.0 * dt) if cut else target
        return min(t.dt, 1.5 * target) if target < t.dt else target

    def forget(self) -> None:
        """A new mesh has no history: no estimate for two steps."""
        if self.controller is not None:
            self.controller.forget()

    def record(self) -> dict | None:
        """What a checkpoint stores of the controller (None without one)."""
        return self.controller.record() if self.controller is not None else None
