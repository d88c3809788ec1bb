"""The ``dpcollapse`` command line: check, run, mesh, plot, validate, sweep, plot-sweep.

The studies (compare, bench, stability, wellposed, ladder) are not part of the installed
solver: ``python -m studies COMMAND`` from a source checkout (studies/cli.py) builds on
:class:`CommandGroup` and :func:`entry`; here their names only say where they went.

Exit status: 0 done, 2 bad input, 3 no convergence, 4 mesh failure, 130 interrupted
(see :mod:`dpcollapse.errors`). Errors are one line on stderr, printed by rank 0 only.
"""

from __future__ import annotations

import os

# One thread per MPI rank: set before anything numeric (numpy, PETSc) is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import logging  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any

import click  # noqa: E402

from dpcollapse import parallel, signals, watchdog  # noqa: E402
from dpcollapse.config import Config, load_config  # noqa: E402
from dpcollapse.errors import (  # noqa: E402
    ConfigError,
    DpcollapseError,
    InternalError,
    Interrupted,
    OutputError,
)
from dpcollapse.parallel import PeerFailed, end_together, install_excepthook  # noqa: E402

try:  # an editable install made before dpcollapse/__init__.py existed sees a namespace package
    from dpcollapse import __version__
except ImportError:
    from importlib.metadata import version as _dist_version

    __version__ = _dist_version("dpcollapse")

_RANK_VARS = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "MV2_COMM_WORLD_RANK")


def _rank() -> int:
    """MPI rank of this process; 0 when not under an MPI launcher.

    mpi4py is imported lazily and only when it is already loaded or a launcher set a rank
    variable, so a serial ``check`` never initializes MPI.
    """
    if "mpi4py.MPI" not in sys.modules and not any(v in os.environ for v in _RANK_VARS):
        return 0
    try:
        from mpi4py import MPI
    except ImportError:
        return 0
    return MPI.COMM_WORLD.rank


def _setup_logging(quiet: bool = False) -> None:
    """INFO on rank 0 (WARNING if quiet), WARNING on the other ranks.

    ``force=True`` because ffcx configures the root logger at import.
    """
    rank = _rank()
    level = logging.WARNING if quiet or rank != 0 else logging.INFO
    fmt = "%(asctime)s %(levelname)s %(name)s" + (f" [rank {rank}]" if rank else "")
    # Third-party loggers (ffcx's JIT build lines, matplotlib) stay at WARNING. setuptools
    # (which the JIT build runs) resets the root level to INFO, so filter on the handler.
    logging.basicConfig(level=logging.WARNING, format=fmt + ": %(message)s", force=True)
    logging.getLogger("dpcollapse").setLevel(level)
    for handler in logging.getLogger().handlers:
        handler.addFilter(_ours_or_warning)


def _ours_or_warning(record: logging.LogRecord) -> bool:
    """Pass dpcollapse's records at their level, everyone else's only from WARNING up."""
    return record.name.startswith("dpcollapse") or record.levelno >= logging.WARNING


def _lazy(module: str, name: str) -> Any:
    """``from module import name`` at call time; a missing module becomes a one-line error."""
    import importlib

    try:
        return getattr(importlib.import_module(module), name)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise DpcollapseError(f"{module} is not available in this installation") from None
        raise


#: Where a bug's traceback goes: the run directory once ``run`` has claimed one.
_error_log_dir: Path | None = None


#: The commands that moved to ``python -m studies`` (a source checkout's studies/ tree).
STUDY_COMMANDS = ("compare", "bench", "stability", "wellposed", "ladder")


class _Group(click.Group):
    """Turns Ctrl-C inside a command into :class:`Interrupted` (exit 130, one line), an I/O
    failure into :class:`OutputError` (exit 5) and any other exception — a bug — into
    :class:`InternalError` (exit 1) whose traceback goes to ``error.log``."""

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        command = super().get_command(ctx, cmd_name)
        if command is None and self is cli and cmd_name in STUDY_COMMANDS:
            raise ConfigError(f"{cmd_name} is a study, not a solver command: from a source "
                              f"checkout's root run python -m studies {cmd_name} "
                              "(docs/architecture.md)")
        return command

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise Interrupted("interrupted") from None
        except (DpcollapseError, click.ClickException, click.Abort, click.exceptions.Exit,
                SystemExit):
            raise
        except OSError as exc:
            where = f" ({exc.filename})" if exc.filename else ""
            raise OutputError(f"I/O failure: {exc.strerror or exc}{where}") from None
        except Exception as exc:
            if signals.received():   # e.g. "ImportError: initialization failed": SIGTERM hit an import
                raise Interrupted("interrupted") from None
            log = _write_traceback()
            raise InternalError(f"internal error: {type(exc).__name__}: {exc} (a bug; traceback "
                                f"in {log})") from None


def _write_traceback() -> str:
    """Write the current exception's traceback to error.log; returns where it went."""
    import tempfile
    import traceback

    text = traceback.format_exc()
    for directory in (_error_log_dir, Path(tempfile.gettempdir())):
        if directory is None:
            continue
        name = "error.log" if directory == _error_log_dir else f"dpcollapse-error-{os.getpid()}.log"
        path = Path(directory) / name
        try:
            path.write_text(text)
            return str(path)
        except OSError:
            path.unlink(missing_ok=True)   # no half-written log left behind
            continue
    return "nowhere: no writable location"


_set_option = click.option(
    "--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
    help="Override one config value (YAML-parsed); repeatable.",
)
_config_arg = click.argument("config", type=click.Path(dir_okay=False, path_type=Path))


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="dpcollapse")
def cli() -> None:
    """Free-surface granular collapses (regularized Drucker–Prager, ALE) on FEniCSx."""


@cli.command()
@_config_arg
@_set_option
def check(config: Path, overrides: tuple[str, ...]) -> int:
    """Validate CONFIG and print the key derived numbers."""
    cfg = load_config(config, overrides)
    if _rank() == 0:
        click.echo(summary(cfg, config))
    return 0


def summary(cfg: Config, source: Path | str | None = None) -> str:
    """A few lines describing a valid config (derived numbers with units): the model's own
    (its factory's ``describe``), then the output directory."""
    from dpcollapse.models.registry import model_factories

    lines = [f"{source}: valid" if source else "config: valid",
             *(f"  {line}" for line in model_factories()[cfg.model.name].describe(cfg)),
             f"  output: {cfg.output.directory}"]
    return "\n".join(lines)


@cli.command()
@_config_arg
@_set_option
@click.option("--out", type=str, default=None,
              help="Run directory (default: output.directory of the config).")
@click.option("--quiet", is_flag=True, help="No progress bar; warnings and errors only.")
@click.option("--resume", is_flag=True, help="Continue from the run directory's last checkpoint.")
@click.option("--overwrite", is_flag=True,
              help="Replace the run already in the run directory (all of its files).")
def run(config: Path, overrides: tuple[str, ...], out: str | None, quiet: bool,
        resume: bool, overwrite: bool) -> int:
    """Simulate the collapse described by CONFIG."""
    if resume and overwrite:
        raise click.UsageError("--resume and --overwrite exclude each other")
    cfg = load_config(config, overrides)
    if quiet:
        _setup_logging(quiet=True)
    from mpi4py import MPI

    from dpcollapse.config import config_to_dict
    from dpcollapse.io.rundir import claim_on_root

    signals.install()   # again: Open MPI 5's MPI_Init resets SIGINT to its default
    watchdog.arm()      # a stop request now ends the run within watchdog.STOP_BOUND s
    if MPI.COMM_WORLD.rank == 0:
        watchdog.prepare_line("nothing of this run was changed since its last checkpoint")

    run_dir = cfg.output.directory if out is None else out
    mode = "resume" if resume else "overwrite" if overwrite else "new"
    global _error_log_dir
    with claim_on_root(MPI.COMM_WORLD, run_dir, config_to_dict(cfg), mode) as claimed:
        _error_log_dir = claimed.path
        run_simulation = _lazy("dpcollapse.simulation", "run_simulation")
        run_simulation(cfg, run_dir=claimed.path, quiet=quiet, resume=resume)
    return 0


@cli.command()
@_config_arg
@_set_option
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Output .msh file (default: meshes/<config stem>.msh).")
def mesh(config: Path, overrides: tuple[str, ...], out: Path | None) -> int:
    """Write the initial mesh of CONFIG as a gmsh .msh file."""
    cfg = load_config(config, overrides)
    from dpcollapse.models.registry import model_factories

    factories = model_factories()
    if not factories[cfg.model.name].meshes_the_scene:
        allowed = ", ".join(sorted(n for n, f in factories.items() if f.meshes_the_scene))
        raise ConfigError(f"model.name = {cfg.model.name}: its mesh is not the scene's (a fixed "
                          f"grid or box); dpcollapse mesh needs model.name = {allowed}")
    path = Path(out or Path("meshes") / f"{config.stem}.msh")
    _check_msh_destination(path)
    write_msh = _lazy("dpcollapse.scenes.registry", "write_msh")
    try:
        write_msh(cfg, path)
    except Exception as exc:   # gmsh raises a bare Exception ("Unable to open file ...")
        if "Unable to open file" not in str(exc):
            raise
        raise ConfigError(f"--out = {path}: cannot be written ({exc})") from None
    return 0


def _check_msh_destination(path: Path) -> None:
    """``mesh --out``: a .msh file in a folder that exists or can be made and is writable."""
    if path.suffix != ".msh":
        raise ConfigError(f"--out = {path}: must end in .msh (gmsh writes the format its "
                          "extension names)")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--out = {path}: cannot create {path.parent} ({exc.strerror})") from None
    if not os.access(path.parent, os.W_OK | os.X_OK) or (path.exists() and not path.is_file()):
        raise ConfigError(f"--out = {path}: cannot be written")


def _parse_times(values: Sequence[str]) -> list[float] | None:
    """'0,0.1' (repeatable) -> [0.0, 0.1]; nothing -> None."""
    items = [s.strip() for v in values for s in v.split(",") if s.strip()]
    if not items:
        return None
    try:
        times = [float(s) for s in items]
    except ValueError:
        raise click.BadParameter(f"{','.join(values)!r}: must be comma-separated numbers (s)",
                                 param_hint="'--times'") from None
    return times


@cli.command()
@click.argument("run_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--times", multiple=True, metavar="T1,T2,...",
              help="Times [s] to plot, comma-separated (default: all outputs).")
def plot(run_dir: Path, times: tuple[str, ...]) -> int:
    """Plot the results in RUN_DIR."""
    parsed = _parse_times(times)
    plot_run = _lazy("dpcollapse.plot", "plot_run")
    plot_run(Path(run_dir), times=parsed)
    return 0


@cli.group()
def validate() -> None:
    """Validation cases against reference solutions (tables + PNG)."""


def _validation(name: str, doc: str, quick_help: str) -> None:
    """Register ``dpcollapse validate NAME``: runs ``dpcollapse.validation.NAME.validate_NAME``
    on ``configs/NAME.yaml`` and writes NAME.csv and NAME.png into --out."""

    @validate.command(name, help=doc)
    @click.option("--config", "config", type=click.Path(dir_okay=False, path_type=Path),
                  default=Path(f"configs/{name}.yaml"), show_default=True,
                  help="Base config of the case.")
    @click.option("--out", type=click.Path(file_okay=False, path_type=Path),
                  default=Path(f"runs/validate_{name}"), show_default=True, help="Output directory.")
    @click.option("--quick", is_flag=True, help=quick_help)
    def command(config: Path, out: Path, quick: bool) -> int:
        if not config.is_file():
            raise ConfigError(f"--config = {config}: file not found")
        geometry = load_config(config).geometry
        shape = geometry.shape
        if not geometry.periodic:   # a collapse config ran for minutes and compared nothing
            raise ConfigError(f"--config = {config}: geometry.shape = {shape}; validate {name} "
                              f"needs a periodic layer (geometry.shape = layer), e.g. "
                              f"configs/{name}.yaml")
        run = _lazy(f"dpcollapse.validation.{name}", f"validate_{name}")
        run(config, out, quick=quick, log=lambda msg: _rank() == 0 and click.echo(msg))
        if _rank() == 0:
            click.echo(f"wrote {out / f'{name}.csv'} and {out / f'{name}.png'}")
        return 0


_validation("plug", "Decelerating plug flow on a periodic inclined plane vs the 1D solution "
            "(seed 000 a).", "Coarse sweeps that finish in about a minute.")
_validation("bagnold", "Steady mu(I) flow down a slope (periodic layer) vs the Bagnold profile, "
            "mesh sweep.", "Two coarse meshes, looser steadiness (about 10 s).")


from dpcollapse.sweep.commands import plot_sweep, sweep  # noqa: E402 (no DOLFINx imported)

cli.add_command(sweep)
cli.add_command(plot_sweep)


def _error(message: str) -> None:
    """One line on stderr, from rank 0 only."""
    if _rank() == 0:
        click.echo("dpcollapse: error: " + " ".join(str(message).split()), err=True)


#: Appended to an interrupt's line under MPI: a signal to Open MPI's mpirun makes mpirun
#: itself exit 1 whatever the ranks return, and kills the ranks odls_base_sigkill_timeout
#: (1 s) after it forwarded the signal (measured with Open MPI 4.1.4, docs/reliability.md).
MPI_INTERRUPT_NOTE = ("; under mpirun its own exit status is the launcher's (Open MPI's: 1 when "
                      "it was signalled): run.json's status says how the run ended")


def _fail(message: str, exit_code: int, peer: bool = False) -> int:
    """Report an error and return its exit status. Under MPI the other ranks are told
    (``peer``: the error is another rank's) and must end too; when one cannot, the whole
    job is aborted instead (:mod:`dpcollapse.parallel`)."""
    if exit_code == Interrupted.exit_code and parallel.several_ranks():
        message = f"{message}{MPI_INTERRUPT_NOTE}"
    end_together(exit_code, " ".join(str(message).split()), peer=peer)
    _error(message)
    return exit_code


def main(argv: list[str] | None = None, group: click.Group | None = None,
         prog_name: str = "dpcollapse") -> int:
    """Run the command line ``group`` (default: the solver's, :data:`cli`; the studies pass
    theirs) on ``argv`` (default: sys.argv[1:]) and return the exit status."""
    _setup_logging()
    try:
        parallel.start()   # the failure protocol's communicator (every rank, same point)
        rv = (group or cli).main(args=argv, prog_name=prog_name, standalone_mode=False)
    except DpcollapseError as exc:
        return _fail(str(exc) or exc.__class__.__name__, exc.exit_code,
                     peer=isinstance(exc, PeerFailed))
    except click.UsageError as exc:
        hint = f" (see '{exc.ctx.command_path} --help')" if exc.ctx else ""
        return _fail(exc.format_message() + hint, exc.exit_code)
    except click.ClickException as exc:
        return _fail(exc.format_message(), exc.exit_code)
    except (click.Abort, KeyboardInterrupt):
        return _fail("interrupted", Interrupted.exit_code)
    return rv if isinstance(rv, int) else 0


def entry(group: click.Group | None = None, prog_name: str = "dpcollapse") -> None:
    """Console script ``dpcollapse`` (and ``python -m studies`` with its own ``group``):
    SIGTERM is an interrupt from the start (exit 130 with one line, also while the run is
    being set up), as Ctrl-C is."""
    signals.install()
    watchdog.install()   # idle until the run command arms it
    install_excepthook()
    code = main(group=group, prog_name=prog_name)
    xdmf = sys.modules.get("dpcollapse.io.xdmf")
    if code and xdmf is not None and xdmf.hdf5_write_failed:
        _exit_without_finalizers(code)
    if code and parallel.out_of_step():
        _leave_out_of_step(code)
    sys.exit(code)


def _exit_without_finalizers(code: int) -> None:
    """Leave now, without the HDF5 and MPI terminators: after a failed HDF5 write, HDF5
    1.14 asserts in them (exit 134 instead of the error's own status). Under mpirun the job
    is aborted with the status, which mpirun passes on: by rank 0, once every rank has
    got here (rank 0 has then written its one line); a rank that aborted first could kill
    rank 0 before its line is out (MPICH's Hydra does)."""
    sys.stdout.flush()
    sys.stderr.flush()
    MPI = sys.modules.get("mpi4py.MPI")
    if MPI is not None and MPI.Is_initialized() and not MPI.Is_finalized() \
            and MPI.COMM_WORLD.size > 1:
        world = MPI.COMM_WORLD
        parallel.all_arrive(parallel.meeting_comm(), parallel.grace_seconds())
        if world.rank != 0:
            time.sleep(parallel.grace_seconds())   # rank 0's abort ends this rank first
        world.Abort(code)
    os._exit(code)


def _leave_out_of_step(code: int) -> None:
    """After an error the ranks stopped at different calls (``parallel.out_of_step``):
    PETSc's terminator (a collective clean-up) would wait forever, so leave without it;
    MPI itself is finalized (the ranks have met in ``parallel.end_together``), so mpirun
    passes the status on. Every rank leaves with the same status at once (no rank waits
    for another: a late signal could then reach the interpreter after MPI_Finalize)."""
    sys.stdout.flush()
    sys.stderr.flush()
    MPI = sys.modules.get("mpi4py.MPI")
    if MPI is not None and MPI.Is_initialized() and not MPI.Is_finalized():
        MPI.Finalize()
    os._exit(code)


#: What a client's command line (``python -m studies``) builds on: the group class that maps
#: exceptions to exit statuses and the rank that prints (0 outside MPI).
CommandGroup = _Group
rank = _rank

__all__ = ["CommandGroup", "cli", "entry", "main", "rank", "summary"]

if __name__ == "__main__":
    entry()
