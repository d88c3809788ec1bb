"""``python -m studies COMMAND``: the studies' command line, run from a source checkout.

The studies (``compare``, ``bench``, ``stability``, ``wellposed``, ``ladder``) run the solver
many times and chart what they find; they are clients of the ``dpcollapse`` package (its
public API, docs/architecture.md) and are not installed with it. Exit statuses and error
lines are the solver's (:func:`dpcollapse.cli.entry`): 0 done, 2 bad input (one line naming
the option and what is allowed), 3 no convergence, 4 mesh failure, 130 interrupted.
"""

from __future__ import annotations

import os

# One thread per MPI rank: set before anything numeric (numpy, PETSc) is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import importlib  # noqa: E402
import logging  # noqa: E402
import math  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import click  # noqa: E402

from dpcollapse.cli import CommandGroup, entry, rank  # noqa: E402
from dpcollapse.cli import main as solver_main  # noqa: E402
from dpcollapse.errors import ConfigError  # noqa: E402

PROG = "python -m studies"


@click.group(cls=CommandGroup, context_settings={"help_option_names": ["-h", "--help"]})
def cli() -> None:
    """Studies of dpcollapse (from a source checkout): method comparisons, benchmarks,
    stability and well-posedness maps, the model ladder."""


def _lazy(module: str, name: str) -> Any:
    """``from module import name`` at call time: ``--help`` imports no DOLFINx."""
    return getattr(importlib.import_module(module), name)


def _quiet_logging() -> None:
    """The solver's INFO lines off (warnings and errors stay): a study runs it many times."""
    logging.getLogger("dpcollapse").setLevel(logging.WARNING)


@cli.command()
@click.argument("case", type=click.Choice(["plug", "collapse"]))
@click.option("--config", "config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Base config (default: configs/plug.yaml or configs/rigid.yaml).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory (default: runs/compare_CASE).")
@click.option("--quick", is_flag=True, help="Two short runs, one per method (checks the harness).")
def compare(case: str, config: Path | None, out: Path | None, quick: bool) -> int:
    """Regularization vs augmented Lagrangian: accuracy against wall time (CSV + PNG) and the
    wall-time ratio at matched accuracy, all measured in this run."""
    config = config or Path("configs/plug.yaml" if case == "plug" else "configs/rigid.yaml")
    out = out or Path(f"runs/compare_{case}")
    if not config.is_file():
        raise ConfigError(f"--config = {config}: file not found")
    _quiet_logging()
    run = _lazy("studies.compare", f"compare_{case}")
    echo = lambda msg: rank() == 0 and click.echo(msg)  # noqa: E731
    runs = run(config, out, quick=quick, log=echo)
    ratio = _lazy("studies.compare", "matched_ratio")(runs)
    if ratio:
        echo(f"matched accuracy {ratio['accuracy']:.3e}: regularized ({ratio['regularized']}) "
             f"{ratio['regularized_wall']:.1f} s, augmented Lagrangian ({ratio['augmented_lagrangian']}) "
             f"{ratio['augmented_lagrangian_wall']:.1f} s: ratio regularized/AL "
             f"{ratio['ratio_regularized_over_al']:.2f}")
    echo(f"wrote {out / f'compare_{case}.csv'} and {out / f'compare_{case}.png'}")
    return 0


@cli.command()
@click.option("--cases", default=None, metavar="NAME,...",
              help="Cases to run, comma-separated: rigid_4cm, rigid_2cm, rigid_1cm, plug, bagnold "
                   "(default: rigid_2cm,rigid_1cm,plug,bagnold; with --quick: rigid_4cm,plug).")
@click.option("--quick", is_flag=True,
              help="Tiny runs (short end times, growth on 2 coarse meshes) to check the harness.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path("runs/bench"), show_default=True, help="Output directory.")
@click.option("--np", "nprocs", type=click.IntRange(min=0), default=2, show_default=True,
              help="Rerun the cases under mpirun -n N and report the speed-up (0: no rerun).")
@click.option("--growth/--no-growth", default=True, show_default=True,
              help="Cost growth: time per step against unknowns on four mesh sizes.")
@click.option("--configs", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder of the case configs (default: the repository's configs/).")
@click.option("--krylov", is_flag=True,
              help="Instead of the suite: iterative (FGMRES + AMG) against MUMPS flow solves on "
                   "the rigid case, Krylov iterations and time per solve against mesh size and "
                   "epsilon (krylov.csv).")
@click.option("--result-json", type=click.Path(dir_okay=False, path_type=Path), default=None,
              hidden=True)
def bench(cases: str | None, quick: bool, out: Path, nprocs: int, growth: bool,
          configs: Path | None, krylov: bool, result_json: Path | None) -> int:
    """Benchmark suite: wall time, iterations, time split, memory, MPI speed-up, cost growth."""
    _quiet_logging()
    if krylov:
        if cases:
            raise click.UsageError("--krylov runs its own grid: --cases does not apply")
        run = _lazy("studies.bench_krylov", "run_krylov_bench")
        run(out, quick=quick, nprocs=nprocs, configs=configs, result_json=result_json,
            echo=click.echo)
        return 0
    parse = _lazy("studies.bench", "parse_cases")
    parse(cases, quick)   # a bad --cases is refused before anything runs
    run = _lazy("studies.bench", "run_bench")
    run(out, cases=cases, quick=quick, nprocs=nprocs, growth=growth, configs=configs,
        result_json=result_json, echo=click.echo)
    return 0


def _number_list(option: str, text: str | None) -> list[float] | None:
    """--epsilons 1e-2,1e-6 → [0.01, 1e-06]; a bad entry is a one-line input error."""
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ConfigError(f"{option} = {text}: must be comma-separated positive numbers") from None
    if not values or not all(v > 0 and math.isfinite(v) for v in values):
        raise ConfigError(f"{option} = {text}: must be comma-separated positive numbers")
    return values


@cli.command()
@click.argument("scene", type=click.Choice(["plug", "rigid"]))
@click.option("--quick", is_flag=True, help="A few short coarse cells (checks the harness, < 1 min).")
@click.option("--config", "config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Base config (default: configs/plug.yaml or configs/rigid.yaml).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory (default: runs/stability_SCENE).")
@click.option("--methods", default=None, metavar="M,...",
              help="Subset of picard, picard+anderson, newton, augmented_lagrangian.")
@click.option("--epsilons", default=None, metavar="E,...", help="epsilon values [1/s] (replace the plan's).")
@click.option("--dts", default=None, metavar="DT,...", help="time steps [s] (replace the plan's).")
@click.option("--mesh-sizes", default=None, metavar="DX,...", help="mesh sizes [m] (replace the plan's).")
@click.option("--end-time", type=float, default=None, help="End time of every run [s].")
@click.option("--cap", type=float, default=None, help="CPU seconds per run before it counts as too slow.")
@click.option("--append", is_flag=True,
              help="Keep the rows of the stability_SCENE.csv already in --out (extend a map run by run).")
def stability(scene: str, quick: bool, config: Path | None, out: Path | None, methods: str | None,
              epsilons: str | None, dts: str | None, mesh_sizes: str | None, end_time: float | None,
              cap: float | None, append: bool) -> int:
    """Map where each method works: method x epsilon x dt x dx, every run classified
    (accurate / wrong / failed with exit code / too slow); CSV + PNG."""
    config = config or Path("configs/plug.yaml" if scene == "plug" else "configs/rigid.yaml")
    out = out or Path(f"runs/stability_{scene}")
    if not config.is_file():
        raise ConfigError(f"--config = {config}: file not found")
    module = "studies.stability"
    plan = _lazy(module, "PLANS")[(scene, quick)]
    known = list(_lazy(module, "METHODS"))
    chosen = plan.methods if methods is None else [m.strip() for m in methods.split(",") if m.strip()]
    bad = [m for m in chosen if m not in known]
    if bad or not chosen:
        raise ConfigError(f"--methods = {methods}: must be a subset of {', '.join(known)}")
    for name, value in (("--end-time", end_time), ("--cap", cap)):
        if value is not None and not (value > 0 and math.isfinite(value)):
            raise ConfigError(f"{name} = {value}: must be > 0")
    import dataclasses

    plan = dataclasses.replace(
        plan, methods=chosen,
        epsilons=_number_list("--epsilons", epsilons) or plan.epsilons,
        dts=_number_list("--dts", dts) or plan.dts,
        mesh_sizes=_number_list("--mesh-sizes", mesh_sizes) or plan.mesh_sizes,
        end_time=end_time or plan.end_time, cap=cap or plan.cap)
    plan.times = [t for t in plan.times if t <= plan.end_time + 1e-9]   # empty: the end time
    _quiet_logging()
    echo = lambda msg: rank() == 0 and click.echo(msg)  # noqa: E731
    _lazy(module, "stability_map")(scene, config, out, quick=quick, plan=plan, log=echo, append=append)
    echo(f"wrote {out / f'stability_{scene}.csv'} and {out / f'stability_{scene}.png'}")
    return 0


@cli.command()
@click.option("--quick", is_flag=True, help="Two tiny cases (3 cm 2D cells; SH dx 4 mm): the test.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("runs/ladder"),
              show_default=True, help="Folder of ladder.csv, ladder_series.csv, ladder.png.")
@click.option("--work", type=click.Path(file_okay=False, path_type=Path), default=Path("runs/ladder"),
              show_default=True, help="Folder of the 2D run directories.")
@click.option("--only", multiple=True, metavar="CASE", help="Run only this case (repeatable).")
@click.option("--redo", is_flag=True, help="Run cases already in the CSV again.")
@click.option("--plot-only", is_flag=True, help="Only redraw the chart and table from the CSVs.")
@click.option("--sh-resolution", "sh_case", default=None, metavar="CASE",
              help="Only the Savage-Hutter side of CASE at dx = 4, 2, 1, 0.5 mm.")
@click.option("--shallow", is_flag=True,
              help="The shallow limit: the aspect-ratio family (ladder_shallow.csv/.png).")
@click.option("--two-phase", "two_phase", is_flag=True,
              help="Add the two-phase rung to the cases already in the CSV (ladder_two_phase.png).")
@click.option("--cells-across", "cells_across", type=click.IntRange(2, 256), default=None,
              metavar="N", help="The two-phase rung's cells across L0 (default 16).")
def ladder(quick: bool, out: Path, work: Path, only: tuple[str, ...], redo: bool, plot_only: bool,
           sh_case: str | None, shallow: bool, two_phase: bool, cells_across: int | None) -> int:
    """The model ladder: each scene with the 2D model and with Savage-Hutter (and with
    --two-phase the two-phase model), runout, deposit height and cost side by side
    (docs/ladder.md)."""
    _quiet_logging()
    echo = lambda msg: rank() == 0 and click.echo(msg)  # noqa: E731
    return _lazy("studies.ladder", "run")(
        quick, out, work, list(only) or None, redo, plot_only, sh_case, echo=echo, shallow=shallow,
        two_phase=two_phase, cells_across=cells_across)


@cli.command()
@click.option("--quick", is_flag=True,
              help="Two cases on two coarse meshes (checks the harness, < 1 min).")
@click.option("--config", "config", type=click.Path(dir_okay=False, path_type=Path),
              default=Path("configs/bagnold.yaml"), show_default=True,
              help="A mu_i layer config (its law, depth, density; slope and mesh are the plan's).")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path("runs/wellposed"), show_default=True, help="Output directory.")
@click.option("--cells", default=None, metavar="N,...",
              help="Cells across the layer, coarse to fine.")
@click.option("--steps", type=int, default=None, help="Time steps per run (> the fit window).")
@click.option("--diffusion-number", type=float, default=None,
              help="beta in dt = beta dx^2/nu_mid (the time step of each mesh).")
def wellposed(quick: bool, config: Path, out: Path, cells: str | None, steps: int | None,
              diffusion_number: float | None) -> int:
    """Ill-posedness of mu(I) measured: growth of grid-scale noise on the Bagnold flow at
    slopes below, inside and above the well-posed window, at 2-3 mesh sizes; CSV + PNG."""
    module = "studies.wellposed"
    plan = _lazy(module, "QUICK" if quick else "FULL")
    if not config.is_file():
        raise ConfigError(f"--config = {config}: file not found")
    n = _number_list("--cells", cells)
    if n is not None and not all(float(c).is_integer() and c >= 2 for c in n):
        raise ConfigError(f"--cells = {cells}: must be comma-separated integers >= 2")
    if steps is not None and not steps > plan.fit_steps:
        raise ConfigError(f"--steps = {steps}: must be > {plan.fit_steps} (the fit window)")
    if diffusion_number is not None and not (0 < diffusion_number < math.inf):
        raise ConfigError(f"--diffusion-number = {diffusion_number}: must be > 0")
    plan = _lazy(module, "plan_with")(plan, cells=n and [int(c) for c in n], n_steps=steps,
                                      diffusion_number=diffusion_number)
    _quiet_logging()
    echo = lambda msg: rank() == 0 and click.echo(msg)  # noqa: E731
    _lazy(module, "wellposedness_map")(config, out, plan, log=echo)
    echo(f"wrote {out / 'stability_mui.csv'} and {out / 'stability_mui.png'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the studies' command line on ``argv`` and return the exit status."""
    return solver_main(argv, group=cli, prog_name=PROG)


if __name__ == "__main__":
    entry(group=cli, prog_name=PROG)
