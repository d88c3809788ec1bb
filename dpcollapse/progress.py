"""The run's progress: a live bar when rank 0 writes to a terminal, else a log line every
``time.output_every`` steps."""

from __future__ import annotations

import logging
import sys

log = logging.getLogger("dpcollapse")


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

            self.bar = tqdm(total=end_time, unit="s",
                            bar_format="{l_bar}{bar}| {n:.3f}/{total:.2f} s{postfix}")
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
            log.info("step %d  t = %.4f s  dt = %.2e s  iterations %d  front %.4f m",
                     step, t, dt, iterations, front)

    def close(self) -> None:
        if self._redirect is not None:
            self._redirect.__exit__(None, None, None)
            self._redirect = None
        if self.bar is not None:
            self.bar.close()
            self.bar = None
