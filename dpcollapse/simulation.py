"""The time loop (``Simulation``): domain step, model step, remesh, diagnostics, output.

The loop drives any model on any domain and knows none: ``models.registry.model_factory``
gives the model of ``model.name`` (``loop.ModelFactory``), which provides the domain
(``domain.base.Domain``), the discretization (``loop.Discretization``) and the checkpoints;
all they add to a run is declared there. Each step n → n+1 (seed 000's update algorithm):
1. if the domain asks for it (``needs_remesh``), remesh and carry the model's state across
   (snapshot/transfer);
2. Δt = min(the step target (``step_size``), the domain's limit (moving: no cell loses more
   than half its area), the model's own (an explicit scheme's CFL and positivity bound));
3. the domain moves by Δt (a move that changes the boundary's tags gives a new
   discretization on the same mesh), the model solves its step; if it fails, or its
   error estimate exceeds ``time.tolerance``, undo the move and retry shorter (halved
   down to ``time.dt_min``);
4. the domain checks the accepted step (moving: the energy balance); the events of the
   domain and the model are counted; diagnostics; XDMF/checkpoint every N steps; stop at
   rest (max |u| below ``time.rest_speed`` for ``time.rest_duration``, or the model's exact
   rest state), by the model's own rule (``stop_reason``) or at the end time.
The state of the loop is a ``loop.LoopState``; subscribers of ``loop.Events`` see new
discretizations, accepted steps, outputs, remeshes and failures.
"""

from __future__ import annotations

import logging
import math
import signal
import time
import uuid
from collections import Counter
from pathlib import Path

from mpi4py import MPI

from dpcollapse import compat, parallel, watchdog
from dpcollapse.config import Config, config_to_dict, save_config
from dpcollapse.domain.base import refuse_degenerate
from dpcollapse.errors import ConfigError, ConvergenceError, DpcollapseError, Interrupted, MeshError
from dpcollapse.fingerprint import check_identity, config_fingerprint
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.io.checkpoint import previous_path, take_not_restored
from dpcollapse.io.diagnostics import DiagnosticsWriter
from dpcollapse.io.exports import CheckpointExport, FieldExport
from dpcollapse.io.runinfo import RunInfo
from dpcollapse.loop import Discretization, Events, LoopState, ModelFactory, run_summary
from dpcollapse.models.registry import model_factory
from dpcollapse.progress import Progress
from dpcollapse.step_size import FEW_ITERATIONS, STEP_GROWTH, StepSize  # noqa: F401 (tests)
from dpcollapse.stop_request import StopRequest

log = logging.getLogger("dpcollapse")


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
        lost: list[str] = []
        if resume:
            disc, state = self.factory.load_checkpoint(self.checkpoint_path, comm)
            self.state = LoopState.from_dict(state)
            self.identity["run_id"] = check_identity(self.state.extra.get("run"), self.identity,
                                                     self.run_dir)
            self._use(disc)
            self._last_measures = self.disc.measures()
            log.info("resuming from t = %.4f s (step %d)", self.state.t, self.state.step)
            lost = take_not_restored(self.state.extra)   # an older version's: said, not silent
        else:
            self.state = LoopState(dt_target=cfg.time.dt)
            self._use(self.factory.start(comm))
            m0 = self._last_measures = self.disc.measures()
            st = self.state
            st.area0, st.gravity_moment0, st.kinetic_energy0 = (
                m0["area"], m0["gravity_moment"], m0["kinetic_energy"])
        #: the named events of the domain and the model (``loop.EventSource``), counted
        self.counted_events = self.domain.counted_events + self.disc.counted_events
        self.state.count_events(self.counted_events)
        parallel.on_root(comm, lambda: save_config(cfg, self.run_dir / "config.yaml"))
        self.field_export = FieldExport(self.run_dir, comm, cfg.output.format, cfg.time.output_every)
        self.checkpoint_export = CheckpointExport(self.checkpoint_path, cfg.time.checkpoint_every)
        if resume:
            self.field_export.truncate_after(self.state.t)
        self.diagnostics = DiagnosticsWriter(self.run_dir / "diagnostics.csv", comm,
                                             resume_after=self.state.t if resume else None,
                                             extra_columns=self.counted_events + self.disc.extra_measures)
        if resume:   # the checkpoint step's row, if the file lost it (cut by a crash)
            parallel.agree(comm, lambda: self.diagnostics.restore(
                {"step": self.state.step, "t": self.state.t, "remeshes": self.state.remeshes,
                 **self.state.event_counts, **self._last_measures}))
        self.info = RunInfo(self.run_dir / "run.json", comm, config_to_dict(cfg),
                            run_id=self.identity["run_id"], history_plot=self.disc.history_plot,
                            time_scheme_chosen=cfg.time_scheme_chosen)   # None: the config's
        if resume:   # this segment's start: exact (every history restored) or what was not
            self.info.update(resume={"t": self.state.t, "step": self.state.step,
                                     "exact": not lost, "not_restored": lost})
            parallel.on_root(comm, self.info.write)
        self.timings = {"solve": 0.0, "mesh_motion": 0.0, "remesh": 0.0, "output": 0.0}
        self.iteration_counts: list[int] = []
        self.step_sizes: list[float] = []
        #: the solver counters of retired discretizations (``Discretization.solver_counts``)
        self.retired_counts: Counter[str] = Counter()
        self.halvings = 0   # step attempts that failed and were retried with dt/2
        #: the step size rules (``step_size``; the error-controlled step's controller)
        self.steps = StepSize(cfg.time, self.state.step_controller)
        self.dt_limit = math.inf
        self.courant = 0.0  # Courant number Δt·max_K |uⁿ|/h_K of the last step
        self.wall0 = time.perf_counter()
        if not resume:
            self._output()

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
        if self.steps.controller is not None:
            self.state.step_controller = self.steps.record()
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
        self.steps.forget()   # the new mesh has no history: no estimate for 2 steps
        self.domain.remeshed(self.disc, self.state)
        self.timings["remesh"] += time.perf_counter() - t0

        log.info("remesh %d at t = %.4f s (%s): area %.8e -> %.8e m² (%+.2e rel), cells %d -> %d, "
                 "%d boundary vertices, max extrapolation %.1e m", self.state.remeshes,
                 self.state.t, reason, area_before, area_after,
                 (area_after - area_before) / area_before, cells_before, cells_after, nverts, outside)
        self.events.emit("remesh", self, {"reason": reason, "area_before": area_before,
                                          "area_after": area_after, "cells_before": cells_before,
                                          "cells_after": cells_after})

    def _retire(self, disc: Discretization) -> None:
        """Destroy a discretization, keeping the counts of its solvers (LU factorizations,
        Krylov iterations, Newton fallbacks)."""
        self.retired_counts.update(disc.solver_counts())
        disc.destroy()

    def solver_counts(self) -> dict[str, int]:
        """The model's solver counters over the whole run (retired and current meshes)."""
        counts = Counter(self.disc.solver_counts())
        counts.update(self.retired_counts)
        return dict(counts)

    def _rebuild(self, tagged: TaggedMesh) -> None:
        """A new discretization on the same mesh with new facet tags; same dofs, so the
        state (uⁿ, iterate, mesh velocity) is copied as arrays. The old one is kept alive
        for the caller to restore or destroy."""
        old = self.disc
        self._use(self.factory.rebuild(tagged))
        self.disc.flow.copy_state_from(old.flow)

    def _step(self) -> tuple[float, int, float]:
        """Advance one step; returns (dt, iterations, residual)."""
        cfg, st = self.cfg, self.state
        reason = self.domain.needs_remesh(self.disc, st)
        if reason:
            self._remesh(reason)
        rate = self.disc.courant_rate()
        dt = self.steps.first_try(st.dt_target, cfg.time.end_time - st.t, rate)
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
        while True:
            token, retagged = domain.move(self.disc, dt)
            before_landing = self.disc
            if retagged is not None:
                self._rebuild(retagged)
            t0 = time.perf_counter()
            report = self.disc.flow.solve_step(dt)
            self.timings["solve"] += time.perf_counter() - t0
            spent += report.iterations
            retry = self.steps.retry(dt, self.disc.flow, st.t) if report.converged else None
            if retry is not None:   # the local error estimate exceeds time.tolerance
                self._undo_attempt(token, retagged, before_landing)
                dt = retry
                domain.recompute(self.disc, dt)
                continue
            if report.converged:
                dt = report.dt or dt   # an explicit stage bound may cut it
                if retagged is not None:
                    self._retire(before_landing)
                break
            self._undo_attempt(token, retagged, before_landing)
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
        self.steps.check_reachable(dt, st.t)   # time.tolerance met at dt_min, else exit 3
        self.disc.flow.accept_step()
        self.courant = dt * rate
        st.t += dt
        st.step += 1
        st.dt_target = self.steps.next_target(dt, st.dt_target, report.iterations,
                                              self.disc.flow.iteration_scale, model_limit)
        return dt, spent, report.residual

    def _undo_attempt(self, token, retagged, before_landing) -> None:
        """Undo a failed or rejected attempt: the mesh back, the rebuild on new facet tags
        (a landing) dropped, the fixed point restarted from the accepted state."""
        self.domain.undo(self.disc, token)
        if retagged is not None:
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
        stop_request = StopRequest()
        previous = {s: signal.signal(s, stop_request) for s in (signal.SIGTERM, signal.SIGINT)}
        # ended at once (a rank failed alone, a stuck mesher): run.json says so, from this rank
        abort_hook = parallel.on_abort(self.info.record_abort)
        agreed_stop = False   # an interrupt every rank agreed on (the ranks are in step)
        watchdog.prepare_run(self.info, self.state, self.comm.rank)   # if it must end the run
        try:
            while st.t < cfg.time.end_time - 1e-12:
                dt, iterations, residual = self._step()
                self.iteration_counts.append(iterations)
                self.step_sizes.append(dt)
                m = self._last_measures = self.disc.measures()
                self.domain.check_step(m, st)   # the moving domain's energy guard
                st.add_events(self.domain.take_events() | self.disc.take_events())
                row = {"step": st.step, "t": st.t, "dt": dt, "dt_limit": self.dt_limit,
                       "courant": self.courant, "iterations": iterations, "residual": residual,
                       "remeshes": st.remeshes, **st.event_counts,
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
                                       or self.disc.exact_rest(m))
                if self.field_export.due(st.step) or at_rest or stop:
                    self._output()
                if self.checkpoint_export.due(st.step) or at_rest or stop:
                    self._checkpoint()
                reason = self.disc.stop_reason(m)   # the model's own (a bin that has discharged)
                if reason and not (at_rest or stop):
                    self._output()
                    self._checkpoint()
                    st.status = reason
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
            status = ("interrupted" if isinstance(exc, DpcollapseError) and exc.exit_code == 130
                      else "failed")
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

    def _finish(self, status: str, progress: Progress, error: str | None = None,
                collective: bool = True) -> dict:
        """Close the outputs and write run.json. ``collective``: the ranks are in step (a
        normal end, an agreed interrupt); otherwise (a failure, possibly on one rank only)
        nothing here waits for another rank and the measures are the last accepted step's."""
        progress.close()
        if collective:
            self.field_export.close()
        self.diagnostics.close()
        m = self.disc.measures() if collective else self._last_measures
        summary = run_summary(status, self.state, m, self.disc, self.iteration_counts, {
            **self.solver_counts(), **self.domain.counters(),
            "halved_steps": self.halvings, "rejected_steps": self.steps.rejected})
        summary.update(model=self.cfg.model.name, **({"error": error} if error else {}))
        self.timings["total"] = time.perf_counter() - self.wall0
        self.info.update(status=status, summary=summary, timings=self.timings)
        watchdog.final()   # this write replaces the watchdog's early record, never the reverse
        self.info.write()
        return summary


def run_simulation(cfg: Config, run_dir: Path, quiet: bool = False, resume: bool = False) -> dict:
    """Run a scene to rest (or end time); returns the summary written to run.json."""
    sim = Simulation(cfg, run_dir, quiet=quiet, resume=resume)
    summary = sim.run()
    if MPI.COMM_WORLD.rank == 0 and not quiet:
        log.info("%s at t = %.4f s after %d steps: front %.4f m, max height %.4f m, area drift %+.2e, "
                 "%d remeshes, %.1f s wall", summary["status"], summary["t"], summary["steps"],
                 summary["front"], summary["max_height"], summary["area_drift"], summary["remeshes"],
                 sim.timings["total"])
        counts = {name: n for name, n in sim.solver_counts().items() if n}
        if counts:
            log.info("%d flow solves; solvers: %s", summary["flow_solves"],
                     ", ".join(f"{name} {n}" for name, n in counts.items()))
    return summary
