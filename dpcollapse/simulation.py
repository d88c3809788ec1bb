"""The time loop: domain step, model step, remesh, diagnostics, output, events.

The loop drives any model on any domain: ``models.registry.model_factory`` gives the model
of ``model.name`` (``loop.ModelFactory``: the 2D flow of ``numerics.method`` with its mesh
motion, or the depth-averaged Savage–Hutter model on a fixed 1D grid), which provides the
domain, the discretization (``loop.Discretization``: model, measures, outputs, step
limit) and the checkpoints. Each step n → n+1 (seed 000's update algorithm):
1. if the domain asks for it (moving: smallest angle below ``numerics.remesh_min_angle``),
   remesh from the current boundary and carry the model's state across (snapshot/transfer);
2. the domain limits Δt (moving: the mesh velocity wⁿ from uⁿ; no cell loses more than
   half its area and no free-surface node more than half its height above the bed); with
   ``time.adaptive`` also Δt ≤ cfl·min_K h_K/max_K |uⁿ| (the Courant bound); the model's
   own limit (an explicit scheme's CFL and positivity bound; none for the 2D flow);
3. the domain moves by Δt·wⁿ (a move that changes the boundary's tags, e.g. front nodes
   landing on the bed, gives a new discretization on the same mesh), the model solves its
   step for (u^{n+1}, p^{n+1});
   if it fails, undo the move and halve Δt down to ``time.dt_min``;
4. record diagnostics; write XDMF/checkpoint every N steps; stop at rest (max |u| below
   ``time.rest_speed`` for ``time.rest_duration``, or a model's exact rest state) or end time.
The state of the loop is a ``loop.LoopState``; subscribers of ``loop.Events`` see new
discretizations, accepted steps, outputs, remeshes and failures.

Step size: fixed ``time.dt`` (a step cut by a failure or the mesh motion recovers ×1.5 per
step), or with ``time.adaptive`` the next target Δt ← ×STEP_GROWTH after a fixed point of
≤ FEW_ITERATIONS iterations, ×STEP_SHRINK after > MANY_ITERATIONS, else unchanged, within
[dt_min, dt_max]; each step then takes min(target, Courant bound, mesh-motion limit).
With ``time.tolerance`` (``time.scheme: bdf2``) the PI controller of
``solvers.step_control`` sets the target from the model's local error estimate; a step whose
estimate exceeds the tolerance is undone (as a failed one) and retried shorter, and counted
in run.json's ``rejected_steps``.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
import signal
import sys
import time
import uuid
from pathlib import Path

import numpy as np
from mpi4py import MPI

from dpcollapse import compat, parallel, signals, watchdog
from dpcollapse.config import Config, config_to_dict, save_config
from dpcollapse.errors import ConfigError, ConvergenceError, Interrupted, MeshError
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.io.checkpoint import previous_path
from dpcollapse.io.diagnostics import DiagnosticsWriter
from dpcollapse.io.runinfo import RunInfo
from dpcollapse.io.exports import CheckpointExport, FieldExport
from dpcollapse.domain.base import refuse_degenerate
from dpcollapse.loop import Discretization, Events, LoopState, ModelFactory
from dpcollapse.models.registry import model_factory
from dpcollapse.solvers.step_control import StepController, ToleranceUnreachable, fit_to_end

log = logging.getLogger("dpcollapse")

#: Energy guard (moving domains): the kinetic energy may exceed the work of gravity by at
#: most this fraction before the run is declared numerically unstable.
ENERGY_TOLERANCE = 0.05
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


class Progress:
    """A live bar when rank 0 writes to a terminal, else a log line every N steps."""

    def __init__(self, comm, end_time: float, every: int, quiet: bool):
        self.rank0 = comm.rank == 0
        self.quiet = quiet
        self.every = every
        self.bar = None
        self._redirect = None
        if self.rank0 and not quiet and sys.stderr.isatty():
            from tqdm import tqdm
            from tqdm.contrib.logging import logging_redirect_tqdm

            self.bar = tqdm(total=end_time, unit="s", bar_format="{l_bar}{bar}| {n:.3f}/{total:.2f} s{postfix}")
            # log lines (remeshes, warnings) go above the bar instead of into it
            root = logging.getLogger()
            filters = [f for h in root.handlers for f in h.filters]
            self._redirect = logging_redirect_tqdm(loggers=[root])
            self._redirect.__enter__()
            for handler in root.handlers:  # keep the CLI's filters (no JIT build noise)
                for f in filters:
                    if f not in handler.filters:
                        handler.addFilter(f)

    def update(self, step: int, t: float, dt: float, iterations: int, front: float) -> None:
        if not self.rank0 or self.quiet:
            return
        if self.bar is not None:
            self.bar.n = t
            self.bar.set_postfix_str(f"step {step} dt {dt:.1e} it {iterations} front {front:.4f} m")
        elif step % self.every == 0:
            log.info("step %d  t = %.4f s  dt = %.2e s  iterations %d  front %.4f m", step, t, dt, iterations, front)

    def close(self) -> None:
        if self._redirect is not None:
            self._redirect.__exit__(None, None, None)
            self._redirect = None
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class _StopRequest:
    """SIGINT/SIGTERM during the loop: the first asks the loop to stop after the step in
    progress (so the checkpoint holds the last accepted step); a second stops at once.
    A signal that came during the set-up and whose KeyboardInterrupt was lost
    (:mod:`dpcollapse.signals`) counts as the first."""

    def __init__(self):
        self.signal: int | None = signal.SIGTERM if signals.received() else None

    def __call__(self, signum, frame):
        if self.signal is not None:
            raise KeyboardInterrupt
        self.signal = signum

    def requested(self, comm) -> bool:
        """Whether any rank was signalled (collective and failure-aware: every rank stops
        at the same step, and a rank that failed alone is noticed here)."""
        return parallel.allreduce(comm, self.signal is not None, op=MPI.LOR)


class Simulation:
    """The run: owns the run directory, the time loop and its state."""

    def __init__(self, cfg: Config, run_dir: Path, quiet: bool = False, resume: bool = False,
                 comm: MPI.Comm = MPI.COMM_WORLD, events: Events | None = None):
        self.cfg, self.comm, self.quiet = cfg, comm, quiet
        #: subscribers to the run's events (``loop.Events``), e.g. a benchmark's timers
        self.events = events or Events()
        #: the model of ``model.name`` (``loop.ModelFactory``)
        self.factory: ModelFactory = model_factory(cfg)
        #: fixed or moving (``domain``)
        self.domain = self.factory.domain()
        if cfg.output.format != "xdmf" and not compat.has_adios2():
            raise ConfigError(f"output.format = {cfg.output.format}: this DOLFINx "
                              f"({compat.DOLFINX_VERSION_TEXT}) has no ADIOS2 (Debian 12's 0.5.2 "
                              "has none); use xdmf")
        self.run_dir = Path(run_dir)
        parallel.on_root(comm, lambda: self.run_dir.mkdir(parents=True, exist_ok=True))
        self.checkpoint_path = self.run_dir / "checkpoint.npz"
        resume = resume and (self.checkpoint_path.exists()
                             or previous_path(self.checkpoint_path).exists())
        #: the run's identity and config fingerprint, stored in every checkpoint
        self.identity = {"fingerprint": config_fingerprint(cfg), "run_id": uuid.uuid4().hex[:12]}
        if resume:
            disc, state = self.factory.load_checkpoint(self.checkpoint_path, comm)
            self.state = LoopState.from_dict(state)
            self.identity["run_id"] = check_identity(self.state.extra.get("run"), self.identity,
                                                     self.run_dir)
            self._use(disc)
            self._last_measures = self.disc.measures()
            log.info("resuming from t = %.4f s (step %d)", self.state.t, self.state.step)
        else:
            self.state = LoopState(dt_target=cfg.time.dt)
            self._use(self.factory.start(comm))
            m0 = self._last_measures = self.disc.measures()
            st = self.state
            st.area0, st.gravity_moment0, st.kinetic_energy0 = (
                m0["area"], m0["gravity_moment"], m0["kinetic_energy"])
        parallel.on_root(comm, lambda: save_config(cfg, self.run_dir / "config.yaml"))
        self.field_export = FieldExport(self.run_dir, comm, cfg.output.format, cfg.time.output_every)
        self.checkpoint_export = CheckpointExport(self.checkpoint_path, cfg.time.checkpoint_every)
        if resume:
            self.field_export.truncate_after(self.state.t)
        self.diagnostics = DiagnosticsWriter(self.run_dir / "diagnostics.csv", comm,
                                             resume_after=self.state.t if resume else None,
                                             extra_columns=self.disc.extra_measures)
        if resume:   # the checkpoint step's row, if the file lost it (cut by a crash)
            restored = parallel.agree(comm, lambda: self.diagnostics.restore(
                {"step": self.state.step, "t": self.state.t, "remeshes": self.state.remeshes,
                 "landings": self.state.landings or 0, **self._last_measures}))
            if restored:
                log.warning("diagnostics.csv ended before the checkpoint (t = %.4f s): its row "
                            "was rebuilt from the checkpoint (dt, iterations: nan); rows between "
                            "them, if any, are lost", self.state.t)
        self.info = RunInfo(self.run_dir / "run.json", comm, config_to_dict(cfg),
                            run_id=self.identity["run_id"])
        self.timings = {"solve": 0.0, "mesh_motion": 0.0, "remesh": 0.0, "output": 0.0}
        self.iteration_counts: list[int] = []
        self.step_sizes: list[float] = []
        #: the solver counters of retired discretizations (``Discretization.solver_counts``)
        self.retired_counts: Counter[str] = Counter()
        self.halvings = 0   # step attempts that failed and were retried with dt/2
        #: the error-controlled step (time.tolerance), else None
        self.controller = StepController(cfg.time.tolerance) if cfg.time.tolerance else None
        self.unreachable = ToleranceUnreachable(TOLERANCE_PATIENCE)   # steps at dt_min above it
        if self.controller is not None and self.state.step_controller is not None:
            self.controller.restore(self.state.step_controller)   # resumed
        self.dt_limit = math.inf
        self.courant = 0.0  # Courant number Δt·max_K |uⁿ|/h_K of the last step
        self.wall0 = time.perf_counter()
        if not resume:
            self._output()

    @property
    def ale_solves(self) -> int:
        """Mesh-velocity solves so far."""
        return self.domain.solves

    # ------------------------------------------------------------------ pieces
    def _use(self, disc: Discretization) -> None:
        """Make ``disc`` the current discretization (event ``discretization``)."""
        self.disc = disc
        self.events.emit("discretization", self, disc)

    def _output(self) -> None:
        t = self.state.t
        if self.field_export.written(t):
            return
        t0 = time.perf_counter()
        self.field_export.write(t, self.disc.mesh, self.disc.output_functions())
        self.timings["output"] += time.perf_counter() - t0
        self.events.emit("output", self, t)

    def _checkpoint(self) -> None:
        if self.state.checkpoint_step == self.state.step:
            return
        self.state.checkpoint_step = self.state.step
        if self.controller is not None:
            self.state.step_controller = self.controller.record()
        t0 = time.perf_counter()
        # rank 0 writes it: every rank shares the outcome (a full disk ends them together)
        parallel.agree(self.comm, lambda: self.checkpoint_export.write(
            self.factory, self.disc, {**self.state.to_dict(), "run": self.identity}))
        self.timings["output"] += time.perf_counter() - t0
        watchdog.prepare_run(self.info, self.state, self.comm.rank)

    def _remesh(self, reason: str) -> None:
        t0 = time.perf_counter()
        old = self.disc
        area_before = old.area()
        cells_before = self.comm.allreduce(compat.num_owned_cells(old.mesh), op=MPI.SUM)
        fields = old.flow.snapshot()
        tagged, nverts = self.domain.remesh(old.tagged, self.state.area0)
        self._retire(old)
        self._use(self.factory.rebuild(tagged))
        outside = self.disc.flow.transfer(fields)
        area_after = self.disc.area()
        cells_after = self.comm.allreduce(compat.num_owned_cells(tagged.mesh), op=MPI.SUM)
        self.state.remeshes += 1
        self.state.last_remesh_step = self.state.step
        if self.controller is not None:   # the new mesh has no history: no estimate for 2 steps
            self.controller.forget()
        self.domain.remeshed(self.disc, self.state)
        self.timings["remesh"] += time.perf_counter() - t0

        log.info("remesh %d at t = %.4f s (%s): area %.8e -> %.8e m² (%+.2e rel), cells %d -> %d, "
                 "%d boundary vertices, max extrapolation %.1e m", self.state.remeshes,
                 self.state.t, reason, area_before, area_after,
                 (area_after - area_before) / area_before, cells_before, cells_after, nverts, outside)
        self.events.emit("remesh", self, {"reason": reason, "area_before": area_before,
                                          "area_after": area_after, "cells_before": cells_before,
                                          "cells_after": cells_after})

    def _check_energy(self, m: dict) -> None:
        """Dissipative flow: KE(t) − KE(0) ≤ W(t), the work of gravity ρ∫f·x dx|₀ᵗ (valid when
        the domain moves with the material). The explicit ALE moves the domain with the
        previous step's velocity, so the kinetic energy of step n−1 is compared with the work
        up to step n. A violation means a numerical instability."""
        st = self.state
        if not self.domain.moving:
            return
        work = m["gravity_moment"] - st.gravity_moment0
        previous = st.kinetic_energy_previous
        gained = (st.kinetic_energy0 if previous is None else previous) - st.kinetic_energy0
        st.kinetic_energy_previous = m["kinetic_energy"]
        if gained > (1 + ENERGY_TOLERANCE) * max(work, 0.0) + 1e-9 * max(abs(st.gravity_moment0), 1.0):
            raise MeshError(
                f"numerically unstable at t = {st.t:.4f} s: the kinetic energy gained "
                f"({gained:.3g} J/m) exceeds the work of gravity ({work:.3g} J/m); min cell angle "
                f"{m.get('min_angle', math.nan):.2f}°: the mass is likely thinner than geometry.mesh_size = "
                f"{self.cfg.geometry.mesh_size:g} m somewhere — use a finer mesh or a shorter time.end_time")

    def _retire(self, disc: Discretization) -> None:
        """Destroy a discretization, keeping the counts of its solvers (LU factorizations,
        Krylov iterations, Newton fallbacks)."""
        self.retired_counts.update(disc.solver_counts())
        disc.destroy()

    def solver_counts(self) -> dict[str, int]:
        """The model's solver counters over the whole run (retired and current meshes)."""
        counts = dict(self.disc.solver_counts())
        for key, value in self.retired_counts.items():
            counts[key] = counts.get(key, 0) + value
        return counts

    def _rebuild(self, tagged: TaggedMesh) -> None:
        """A new discretization on the same mesh with new facet tags; same dofs, so the
        state (uⁿ, iterate, mesh velocity) is copied as arrays. The old one is kept alive
        for the caller to restore or destroy."""
        old = self.disc
        self._use(self.factory.rebuild(tagged))
        self.disc.flow.copy_state_from(old.flow)

    def _next_target(self, dt: float, iterations: int) -> float:
        """Adaptive target of the next step from this step's Δt and fixed-point iterations."""
        t = self.cfg.time
        # an augmented Lagrangian iteration is one back-substitution, not a factorization:
        # measured 3 ms against 15 ms per Picard iteration on the 2 cm collapse
        scale = self.disc.flow.iteration_scale
        if iterations <= FEW_ITERATIONS * scale:
            dt *= STEP_GROWTH
        elif iterations > MANY_ITERATIONS * scale:
            dt *= STEP_SHRINK
        return min(max(dt, t.dt_min), t.dt_max)

    def _step(self) -> tuple[float, int, float]:
        """Advance one step; returns (dt, iterations, residual)."""
        cfg, st = self.cfg, self.state
        reason = self.domain.needs_remesh(self.disc, st)
        if reason:
            self._remesh(reason)
        dt = fit_to_end(st.dt_target, cfg.time.end_time - st.t, cfg.time.dt_min)   # no sliver left
        rate = self.disc.courant_rate()
        if cfg.time.adaptive and rate > 0:
            dt = min(dt, max(cfg.time.cfl / rate, cfg.time.dt_min))
        domain = self.domain
        t0 = time.perf_counter()
        limit = self.dt_limit = domain.limit_step(self.disc, dt)
        self.timings["mesh_motion"] += time.perf_counter() - t0
        if limit < dt:
            log.debug("t = %.4f s: dt limited by the mesh motion to %.2e s", st.t, limit)
        if limit < dt and limit < cfg.time.dt_min:   # cut below dt_min (not a last short step)
            if st.step - st.last_remesh_step > 0:
                self._remesh(f"step limit {limit:.1e} s below dt_min")
                return self._step()
            raise MeshError(f"mesh degenerate at t = {st.t:.4f} s: the largest step that "
                            f"keeps every cell valid is {limit:.1e} s < time.dt_min, even after a remesh")
        dt = min(dt, limit)
        model_limit = self.disc.max_step()   # an explicit scheme's CFL bound; inf: none
        self.dt_limit = min(limit, model_limit)
        dt = min(dt, model_limit)
        spent = 0  # iterations of failed attempts of this step (they cost as much)
        error = None   # the local error estimate of the accepted step (time.tolerance)
        while True:
            token, retagged, landed = domain.move(self.disc, dt)
            before_landing = self.disc
            if retagged is not None:
                self._rebuild(retagged)
            t0 = time.perf_counter()
            report = self.disc.flow.solve_step(dt)
            self.timings["solve"] += time.perf_counter() - t0
            spent += report.iterations
            if report.converged and self.controller is not None:
                error = self.disc.flow.local_error()
                if error is not None and dt > cfg.time.dt_min and not self.controller.accept(error):
                    retry = max(self.controller.retry_step(dt, error), cfg.time.dt_min)
                    log.debug("t = %.4f s: step %.2e s rejected (local error %.2e m/s > %.2e); "
                              "retried with %.2e s", st.t, dt, error, cfg.time.tolerance, retry)
                    self._undo_attempt(token, landed, before_landing)
                    dt = retry
                    domain.recompute(self.disc, dt)
                    continue
            if report.converged:
                dt = getattr(report, "dt", None) or dt   # an explicit stage bound may cut it
                if landed:
                    st.landings = (st.landings or 0) + landed
                    log.debug("t = %.4f s: %d nose node(s) landed on the bed", st.t + dt, landed)
                    self._retire(before_landing)
                break
            self._undo_attempt(token, landed, before_landing)
            if dt / 2 < cfg.time.dt_min:
                refuse_degenerate(domain, self.disc, st.t, dt, report.message)   # exit 4, not 3
                raise ConvergenceError(
                    f"the fixed point did not converge at t = {st.t:.4f} s even with dt = "
                    f"{dt:.1e} s (time.dt_min = {cfg.time.dt_min:g}): {report.message}, residual "
                    f"{report.residual:.2e}; try a larger numerics.max_iterations or numerics.epsilon")
            log.warning("t = %.4f s: no convergence with dt = %.2e s (%s, residual %.2e); halving dt",
                        st.t, dt, report.message, report.residual)
            self.halvings += 1
            dt /= 2
            domain.recompute(self.disc, dt)
        if self.controller is not None:   # exit 3 when time.tolerance is out of reach at dt_min
            self.unreachable.check(dt, error, cfg.time.tolerance, cfg.time.dt_min, st.t)
        self.disc.flow.accept_step()
        self.courant = dt * rate
        st.t += dt
        st.step += 1
        if cfg.time.adaptive:
            st.dt_target = self._next_target(dt, report.iterations)
            return dt, spent, report.residual
        if self.controller is not None:
            target = self.controller.next_step(dt, error)
            st.dt_target = min(max(target, cfg.time.dt_min), cfg.time.dt_max)
            return dt, spent, report.residual
        cut = dt < min(st.dt_target, model_limit)   # by a failure, the domain or end_time
        st.dt_target = min(cfg.time.dt, 2.0 * dt) if cut else st.dt_target
        if st.dt_target < cfg.time.dt:
            st.dt_target = min(cfg.time.dt, 1.5 * st.dt_target)
        return dt, spent, report.residual

    def _undo_attempt(self, token, landed: int, before_landing) -> None:
        """Undo a failed or rejected attempt: the mesh back, the landing rebuild dropped, the
        fixed point restarted from the accepted state."""
        self.domain.undo(self.disc, token)
        if landed:
            self._retire(self.disc)
            self.disc = before_landing
        self.disc.flow.reset_iterate()

    # ------------------------------------------------------------------ loop
    def run(self, observers=()) -> dict:
        """The time loop. Each ``observer(sim)`` is called after every accepted step, before
        the ``step_accepted`` subscribers (``loop``); one that returns True ends the run
        cleanly after that step (files written as at rest, status "stopped_by_observer").
        Under MPI it must return the same value on every rank."""
        cfg, st = self.cfg, self.state
        progress = Progress(self.comm, cfg.time.end_time, cfg.time.output_every, self.quiet)
        stop_request = _StopRequest()
        previous = {s: signal.signal(s, stop_request) for s in (signal.SIGTERM, signal.SIGINT)}
        # ended at once (a rank failed alone, a stuck mesher): run.json says so, from this rank
        abort_hook = parallel.on_abort(self._record_abort)
        agreed_stop = False   # an interrupt every rank agreed on (the ranks are in step)
        watchdog.prepare_run(self.info, self.state, self.comm.rank)   # if it must end the run
        try:
            while st.t < cfg.time.end_time - 1e-12:
                dt, iterations, residual = self._step()
                self.iteration_counts.append(iterations)
                self.step_sizes.append(dt)
                m = self._last_measures = self.disc.measures()
                self._check_energy(m)
                row = {"step": st.step, "t": st.t, "dt": dt, "dt_limit": self.dt_limit,
                       "courant": self.courant,
                       "iterations": iterations,
                       "residual": residual, "remeshes": st.remeshes, "landings": st.landings or 0,
                       "wall_time": time.perf_counter() - self.wall0, **m}
                parallel.agree(self.comm, lambda: self.diagnostics.write(row))   # rank 0's
                stop = any([bool(observe(self)) for observe in observers]
                           + [bool(v) for v in self.events.emit("step_accepted", self, row)])
                progress.update(st.step, st.t, dt, iterations, m["front"])
                st.kinetic_energy_peak = max(st.kinetic_energy_peak or 0.0, m["kinetic_energy"])
                resting = (m["max_speed"] < cfg.time.rest_speed
                           or m["kinetic_energy"] < cfg.time.rest_energy_fraction * st.kinetic_energy_peak)
                st.rest_time = st.rest_time + dt if resting else 0.0
                at_rest = resting and (st.rest_time >= cfg.time.rest_duration
                                       or m.get("at_rest", False))
                if self.field_export.due(st.step) or at_rest or stop:
                    self._output()
                if self.checkpoint_export.due(st.step) or at_rest or stop:
                    self._checkpoint()
                emptied = bool(m.get("emptied", False))   # a bin that has discharged
                if emptied and not (at_rest or stop):
                    self._output()
                    self._checkpoint()
                    st.status = "emptied"
                    break
                if at_rest or stop:
                    st.status = "at_rest" if at_rest else "stopped_by_observer"
                    break
                watchdog.safe_point()   # a stop request is honoured here (else the watchdog)
                if stop_request.requested(self.comm):   # after an accepted step: save it
                    self._output()
                    self._checkpoint()
                    agreed_stop = True
                    raise KeyboardInterrupt
            else:
                st.status = "end_time"
                self._output()
                self._checkpoint()
        except KeyboardInterrupt:
            self._finish("interrupted", progress, collective=agreed_stop)
            raise Interrupted(f"stopped at t = {st.t:.4f} s; the run directory is valid, "
                              f"continue with --resume") from None
        except (ConvergenceError, MeshError) as exc:
            if "t = " not in str(exc):      # say when
                exc = type(exc)(f"after t = {st.t:.4f} s: {exc}")
            self.events.emit("failure", self, exc)
            self._finish("failed", progress, error=str(exc), collective=False)
            raise exc from None
        except Exception as exc:       # an I/O failure, another rank's failure or a bug:
            self.events.emit("failure", self, exc)   # say so in run.json if we can
            status = "interrupted" if getattr(exc, "exit_code", None) == 130 else "failed"
            error = str(exc) if isinstance(exc, parallel.PeerFailed) else f"{type(exc).__name__}: {exc}"
            try:
                self._finish(status, progress, error=error, collective=False)
            except Exception:          # e.g. the disk is still full
                pass
            raise
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
        parallel.remove_abort_hook(abort_hook)
        return self._finish(st.status, progress)

    def _record_abort(self, exit_code: int, message: str) -> None:
        """The job is ended at once (``parallel.on_abort``): run.json from this rank."""
        from dpcollapse.io.runinfo import write_json_atomic

        self.info.update(status="interrupted" if exit_code == 130 else "failed",
                         summary={**self.info.data.get("summary", {}), "error": message})
        write_json_atomic(self.info.path, self.info.data)

    def _finish(self, status: str, progress: Progress, error: str | None = None,
                collective: bool = True) -> dict:
        """Close the outputs and write run.json. ``collective``: the ranks are in step (a
        normal end, an agreed interrupt); otherwise (a failure, possibly on one rank only)
        nothing here waits for another rank and the measures are the last accepted step's."""
        progress.close()
        if collective:
            self.field_export.close()
        self.diagnostics.close()
        its = self.iteration_counts
        m = self.disc.measures() if collective else self._last_measures
        summary = {
            "status": status, "t": self.state.t, "steps": self.state.step,
            "remeshes": self.state.remeshes, "front": m["front"], "max_height": m["max_height"],
            "thick_front": m["thick_front"], "film_threshold": self.disc.film_threshold,
            "landings": self.state.landings or 0,
            # the area that left through an outflow side is outflow, not a loss
            "area": m["area"], "area_drift": (m["area"] + m.get("outflow_area", 0.0)
                                              - self.state.area0) / self.state.area0,
            "kinetic_energy": m["kinetic_energy"],
            "mean_iterations": float(np.mean(its)) if its else 0.0,
            "max_iterations": int(np.max(its)) if its else 0,
            "flow_solves": int(np.sum(its)) if its else 0,
            **self.solver_counts(),
            "mesh_velocity_factorizations": self.ale_solves,
            "halved_steps": self.halvings,
            "rejected_steps": self.controller.rejected if self.controller else 0,
        }
        summary.update({k: _finite(m[k]) for k in self.disc.extra_measures})
        summary.update(self.disc.summary_measures())   # a model's own
        summary["model"] = self.cfg.model.name
        if error:
            summary["error"] = error
        self.timings["total"] = time.perf_counter() - self.wall0
        self.info.update(status=status, summary=summary, timings=self.timings)
        self.info.write()
        return summary


def config_fingerprint(cfg: Config) -> str:
    """Hash of the config without the keys a resume may change (``io.rundir.RESUMABLE_KEYS``)."""
    return _fingerprint(config_to_dict(cfg))


def _fingerprint(data: dict) -> str:
    """``config_fingerprint`` of a config as a plain dict (e.g. a run's config.yaml)."""
    import copy
    import hashlib
    import json

    from dpcollapse.io.rundir import RESUMABLE_KEYS

    data = copy.deepcopy(data)
    for key in RESUMABLE_KEYS:
        section, name = key.split(".")
        data.get(section, {}).pop(name, None)
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _saved_fingerprint(run_dir: Path) -> str | None:
    """The fingerprint the run's program gave its config.yaml (as written, before this program
    read it: a program older than a key hashed a config without it); None if unreadable."""
    import yaml

    try:
        data = yaml.safe_load((run_dir / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return None
    return _fingerprint(data) if isinstance(data, dict) else None


def check_identity(stored: dict | None, mine: dict, run_dir: Path) -> str:
    """The run id to continue under: the checkpoint's, when it was written by this run
    (its config fingerprint is this config's, or — written by an older program, whose config
    lacked keys added since — the one of the run's config.yaml, which ``io.rundir`` has found
    equal to this config; and the run id run.json names). A checkpoint of another run (copied
    in) is ConfigError naming both; one older than fingerprints is trusted."""
    import json

    if not stored:
        log.warning("the checkpoint predates run fingerprints: it is trusted to be this run's")
        return mine["run_id"]
    try:
        owner = json.loads((run_dir / "run.json").read_text()).get("run_id")
    except (OSError, ValueError, AttributeError):
        owner = None
    ours = stored.get("fingerprint") in (mine["fingerprint"], _saved_fingerprint(run_dir))
    if not ours or (owner and stored.get("run_id") != owner):
        raise ConfigError(
            f"--resume: the checkpoint in {run_dir} belongs to another run (run "
            f"{stored.get('run_id')}, config fingerprint {stored.get('fingerprint')}) than this "
            f"one (run {owner or 'unknown'}, config fingerprint {mine['fingerprint']}): was it "
            "copied in? Start the run again with --overwrite")
    return stored.get("run_id") or mine["run_id"]


def _finite(value: float) -> float | None:
    """None for a measure the model does not have (NaN), for run.json."""
    return value if value == value else None


def run_simulation(cfg: Config, run_dir: Path, quiet: bool = False, resume: bool = False) -> dict:
    """Run a scene to rest (or end time); returns the summary written to run.json."""
    sim = Simulation(cfg, run_dir, quiet=quiet, resume=resume)
    summary = sim.run()
    if MPI.COMM_WORLD.rank == 0 and not quiet:
        log.info("%s at t = %.4f s after %d steps: front %.4f m, max height %.4f m, area drift %+.2e, "
                 "%d remeshes, %.1f s wall", summary["status"], summary["t"], summary["steps"],
                 summary["front"], summary["max_height"], summary["area_drift"], summary["remeshes"],
                 sim.timings["total"])
        if summary.get("krylov_iterations"):
            log.info("%d flow solves, %d Krylov iterations (%.1f per solve)", summary["flow_solves"],
                     summary["krylov_iterations"],
                     summary["krylov_iterations"] / max(summary["flow_solves"], 1))
    return summary
