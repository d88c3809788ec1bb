"""``dpcollapse sweep`` and ``dpcollapse plot-sweep`` (added to :mod:`dpcollapse.cli`).

Errors are returned as exit statuses here, not raised to :func:`dpcollapse.cli.main`:
under ``python -m mpi4py.futures`` the worker ranks never join the driver's error
handshake, so the driver reports its one line and exits alone.
"""

from __future__ import annotations

import logging
from pathlib import Path

import click

from dpcollapse.errors import DpcollapseError

log = logging.getLogger("dpcollapse.sweep")


def _fail(exc: DpcollapseError) -> int:
    """The one line, from the first rank only when several were launched (under a plain
    ``mpirun -n N dpcollapse sweep`` every rank refuses; the line is printed once)."""
    from dpcollapse.sweep.executors import launched_rank

    if launched_rank() == 0:
        click.echo("dpcollapse: error: " + " ".join(str(exc).split()), err=True)
    return exc.exit_code


@click.command()
@click.argument("sweep_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--executor", type=click.Choice(["local", "mpi", "slurm"]), default="local",
              show_default=True, help="local processes; mpi4py.futures workers; a SLURM job "
              "array script (not submitted).")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="local: cases at once (default 1); slurm: array tasks at once (%N).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Sweep directory (default: runs/<sweep file name>).")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override a config value in every case (e.g. a shorter time.end_time).")
@click.option("--collect", is_flag=True, help="Only write sweep.csv from the run directories.")
@click.option("--dry-run", is_flag=True, help="Validate and list the cases and what would run.")
@click.option("--retry-failed", is_flag=True, help="Run failed cases again (default: keep).")
@click.option("--task", type=int, default=None, metavar="I",
              help="Run case I only (what each SLURM array task does).")
@click.option("--fingerprint", default=None, hidden=True)
def sweep(sweep_file: Path, executor: str, jobs: int | None, out: Path | None,
          overrides: tuple[str, ...], collect: bool, dry_run: bool, retry_failed: bool,
          task: int | None, fingerprint: str | None) -> int:
    """Run the cases of SWEEP_FILE, each a 'dpcollapse run' in its own directory, and write
    sweep.csv (one row per case). Running it again skips finished cases and resumes
    interrupted ones."""
    try:
        code = _sweep(sweep_file, executor, jobs, out, overrides, collect, dry_run,
                      retry_failed, task, fingerprint)
    except DpcollapseError as exc:
        code = _fail(exc)
    if executor == "mpi":
        from dpcollapse.sweep.executors import mpi_exit_status

        code = mpi_exit_status(code)
    return code


def _sweep(sweep_file, executor, jobs, out, overrides, collect, dry_run, retry_failed, task,
           fingerprint) -> int:
    from dpcollapse.errors import ConfigError
    from dpcollapse.sweep import collect as coll
    from dpcollapse.sweep import executors as ex
    from dpcollapse.sweep.spec import load_sweep

    if jobs is not None and executor == "mpi":
        raise ConfigError("--jobs: not with --executor mpi (one case per worker rank: "
                          "choose the number of ranks of mpirun)")
    if executor != "mpi" and ex.launched_ranks() > 1 and ex._futures_lib() is None:
        raise ConfigError("dpcollapse sweep runs as one process (each rank would run every "
                          "case); under mpirun use 'python -m mpi4py.futures' and --executor mpi")
    sw = load_sweep(sweep_file, overrides)
    out = Path(out or Path("runs") / sweep_file.stem)
    if fingerprint is not None and fingerprint != sw.fingerprint:
        raise ConfigError(f"sweep file {sweep_file}: changed since the SLURM script was written "
                          "(cases or configs differ); write it again with --executor slurm")
    if collect:
        table = coll.collect(sw, out)
        line = coll.progress_line(table)
        coll.write_atomic(out / "progress.txt", line + "\n")
        click.echo(f"wrote {out / 'sweep.csv'}: {line}")
        return 0
    if dry_run:
        for case in sw.cases:
            state = coll.case_state(out, case)
            click.echo(f"{case.index:4d} {case.name}: {state.state}"
                       + (f" ({state.status})" if state.status else "")
                       + f" -> {ex.decide(out, case, retry_failed)}")
        click.echo(f"{len(sw.cases)} cases, all valid; sweep directory {out}")
        return 0
    if task is not None:
        return ex.run_one(sw, out, task, retry_failed)
    if executor == "slurm":
        array, collect_script = ex.write_slurm(sw, out, list(overrides), jobs)
        click.echo(f"wrote {array} ({len(sw.cases)} array tasks) and {collect_script}\n"
                   f"submit: {ex.submit_hint(array, collect_script)}")
        return 0
    table = ex.run_sweep(sw, out, executor, jobs or 1, retry_failed)
    click.echo(f"wrote {out / 'sweep.csv'}: {coll.progress_line(table)}")
    return 0


@click.command("plot-sweep")
@click.argument("sweep_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--x", "x", required=True, metavar="KEY", help="Varied parameter on the x axis "
              "(section.key or its key).")
@click.option("--y", "y", default="runout", show_default=True, metavar="COLUMN",
              help="Column of sweep.csv to plot.")
@click.option("--by", default=None, metavar="KEY", help="One line per value of this parameter.")
@click.option("--where", multiple=True, metavar="KEY=VALUE", help="Only the rows with this value.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="PNG file (default: SWEEP_DIR/<y>_vs_<x>.png).")
def plot_sweep(sweep_dir: Path, x: str, y: str, by: str | None, where: tuple[str, ...],
               out: Path | None) -> int:
    """PNG of a sweep.csv column against one parameter, a line per value of another."""
    from dpcollapse.sweep.plot import plot_sweep as plot

    try:
        path = plot(sweep_dir, x, y, by, where, out)
    except DpcollapseError as exc:
        return _fail(exc)
    click.echo(f"wrote {path}")
    return 0
