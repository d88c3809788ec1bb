"""`python -m studies bench`: the harness on tiny cases (no time assertions: benchmarks are not
timed tests), and the instrumentation leaving the results untouched."""

import csv
import json
import math

import numpy as np
import pytest

from studies.bench import (
    COLUMNS,
    PARTS,
    Instrument,
    default_configs_dir,
    fitted_exponent,
    instrumented_simulation,
    load_case_config,
)
from studies.cli import main


def _rows(path):
    with path.open() as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    status = main(["bench", "--quick", "--np", "0", "--out", str(out)])
    return status, out


def test_quick_exit_status_and_files(quick):
    status, out = quick
    assert status == 0
    assert (out / "bench.png").stat().st_size > 10_000
    data = json.loads((out / "bench.json").read_text())
    assert data["quick"] and data["mpi_size"] == 1
    assert math.isfinite(data["exponents"]["time_per_step"])
    assert math.isfinite(data["exponents"]["linear_solve"])


def test_quick_csv_rows_and_columns(quick):
    _, out = quick
    header, rows = _rows(out / "bench.csv")
    assert tuple(header) == COLUMNS
    assert [(r["kind"], r["case"], r["np"]) for r in rows] == [
        ("case", "rigid_4cm", "1"), ("case", "plug", "1"),
        ("growth", "rigid_4cm", "1"), ("growth", "rigid_2cm", "1")]
    growth = [r for r in rows if r["kind"] == "growth"]
    assert int(growth[1]["dofs"]) > int(growth[0]["dofs"])
    assert len({r["growth_exponent"] for r in growth}) == 1 and growth[0]["growth_exponent"]
    for r in rows:
        assert r["status"] == "end_time", r
        assert int(r["steps"]) > 0 and float(r["wall_s"]) > 0 and float(r["peak_mb"]) > 0
        # every Picard iteration is one flow solve (the instrumentation missed none)
        assert float(r["flow_solves_per_step"]) == pytest.approx(float(r["mean_iterations"]))
        assert float(r["linear_solves_per_step"]) >= float(r["flow_solves_per_step"])
        # Δt statistics: mean = simulated time / steps, between the smallest and largest step
        dt_min, dt_mean, dt_max = (float(r[k]) for k in ("dt_min_s", "dt_mean_s", "dt_max_s"))
        assert dt_mean == pytest.approx(float(r["sim_time"]) / int(r["steps"]), rel=1e-5)
        assert 0 < dt_min <= dt_mean * (1 + 1e-5) and dt_mean <= dt_max * (1 + 1e-5)


def test_quick_percentages_and_overhead(quick):
    _, out = quick
    _, rows = _rows(out / "bench.csv")
    for r in rows:
        pct = [float(r[f"pct_{p}"]) for p in PARTS]
        assert all(p >= -1e-6 for p in pct), r
        assert sum(pct) <= 100.0 + 1e-3, r
        assert sum(pct[:3]) > 0   # assembly + factorization + solve were timed
        assert float(r["overhead_ratio"]) >= 1.0, r


def test_bad_case_is_refused(tmp_path, capsys):
    assert main(["bench", "--cases", "rigid_2cm,nope", "--np", "0", "--out", str(tmp_path)]) == 2
    assert "nope" in capsys.readouterr().err


def test_fitted_exponent():
    n = np.array([1e3, 4e3, 1.6e4, 6.4e4])
    assert fitted_exponent(n, 3e-6 * n**1.3) == pytest.approx(1.3)
    assert math.isnan(fitted_exponent([1e3], [1.0]))


def test_instrumentation_changes_nothing(tmp_path, monkeypatch):
    """A run whose discretizations a benchmark tracks (event ``discretization``) gives
    bit-identical diagnostics, and every new discretization (here: a remesh every 5 steps)
    is tracked, with its solves, factorizations and their times."""
    from dpcollapse.domain import moving
    from dpcollapse.simulation import Simulation

    # a remesh every 5 steps: an unreachable threshold, and no lowering of it after a remesh
    monkeypatch.setattr(moving, "REMESH_DEGRADATION", math.inf)

    cfg = load_case_config(default_configs_dir(), "rigid.yaml",
                           ("geometry.mesh_size=0.04", "time.end_time=0.012",
                            "numerics.remesh_min_angle=59"))
    plain = Simulation(cfg, tmp_path / "plain", quiet=True)
    plain.run()
    plain.disc.destroy()
    instrument = Instrument()
    sim = instrumented_simulation(instrument, cfg, tmp_path / "timed", quiet=True)
    sim.run()
    sim.disc.destroy()
    assert sim.state.remeshes >= 2
    assert instrument.wrapped >= 1 + sim.state.remeshes
    assert instrument.linear_solves == instrument.factorizations == sum(sim.iteration_counts)
    assert instrument.times["factorization"] > 0

    def diagnostics(run):
        _, rows = _rows(tmp_path / run / "diagnostics.csv")
        return np.array([[float(v) for k, v in r.items() if k != "wall_time"] for r in rows])

    a, b = diagnostics("plain"), diagnostics("timed")
    assert a.shape == b.shape and a.shape[0] == sim.state.step
    assert np.array_equal(a, b, equal_nan=True)


def test_mpi_rerun_and_speedup(tmp_path):
    """--np 2: the cases rerun under mpirun as a subprocess; the speed-up is reported."""
    import shutil

    assert shutil.which("mpirun") or shutil.which("mpiexec"), \
        "no MPI launcher on PATH: scripts/setup.sh installs openmpi-bin"
    status = main(["bench", "--quick", "--cases", "rigid_4cm", "--np", "2", "--no-growth",
                   "--out", str(tmp_path)])
    assert status == 0
    _, rows = _rows(tmp_path / "bench.csv")
    assert [(r["case"], r["np"]) for r in rows] == [("rigid_4cm", "1"), ("rigid_4cm", "2")]
    assert rows[0]["speedup"] == "" and float(rows[1]["speedup"]) > 0
    assert rows[0]["steps"] == rows[1]["steps"]
    assert float(rows[1]["mean_iterations"]) == pytest.approx(float(rows[0]["mean_iterations"]))


@pytest.mark.mpi
def test_harness_on_all_ranks(shared_tmp, comm):
    """Run by the MPI test pass on 2 ranks: rows reduced over ranks, rank 0 writes."""
    status = main(["bench", "--quick", "--cases", "plug", "--np", "0", "--no-growth",
                   "--out", str(shared_tmp / "bench")])
    assert status == 0
    comm.barrier()
    _, rows = _rows(shared_tmp / "bench" / "bench.csv")
    assert [(r["case"], r["np"]) for r in rows] == [("plug", str(comm.size))]
    assert sum(float(rows[0][f"pct_{p}"]) for p in PARTS) <= 100.0 + 1e-3
    assert float(rows[0]["overhead_ratio"]) >= 1.0


def test_krylov_grid_quick(tmp_path, capsys):
    """bench --krylov --quick: first steps, one row per (ε, solver) on the 4 cm mesh, Krylov
    iterations for the iterative rows, the same Picard solves and front as MUMPS, the
    LU/iterative ratio; then one solve per (ε, solver) of the developed state."""
    from studies.bench_krylov import COLUMNS as KRYLOV_COLUMNS
    from studies.bench_krylov import QUICK_DEVELOPED, QUICK_PLAN

    assert main(["bench", "--krylov", "--quick", "--np", "0", "--out", str(tmp_path)]) == 0
    assert "LU/it" in capsys.readouterr().out
    header, rows = _rows(tmp_path / "krylov.csv")
    assert tuple(header) == KRYLOV_COLUMNS
    first = [r for r in rows if r["kind"] == "first_steps"]
    assert [(r["solver"], float(r["epsilon"])) for r in first] == [
        (s, e) for e in QUICK_PLAN.epsilons for s in QUICK_PLAN.solvers]
    for it, lu in zip(first[::2], first[1::2]):
        assert it["status"] == lu["status"] == "end_time"
        assert int(it["solves"]) == int(lu["solves"]) > 0
        # measured at 4 cm: 37–40 per solve, at most 76; a preconditioner that stopped
        # working would need hundreds (the cap is 500)
        assert 1 <= float(it["krylov_mean"]) <= int(it["krylov_max"]) <= 150
        assert lu["krylov_mean"] == "" and float(it["lu_over_iterative"]) > 0
        assert float(it["front"]) == pytest.approx(float(lu["front"]), abs=1e-9)
    developed = [r for r in rows if r["kind"] == "developed"]
    assert [(r["solver"], float(r["epsilon"])) for r in developed] == [
        (s, e) for e in QUICK_DEVELOPED.epsilons for s in ("iterative", "mumps")]
    for r in developed:
        assert float(r["t"]) == pytest.approx(QUICK_DEVELOPED.end_time)
        assert r["status"] == "ok"   # at 4 cm the developed state converges (measured 44–46)
        if r["solver"] == "iterative":
            assert 1 <= float(r["krylov_mean"]) <= 150
        assert float(r["time_per_solve_s"]) > 0


def test_krylov_grid_refuses_cases(tmp_path, capsys):
    assert main(["bench", "--krylov", "--cases", "plug", "--out", str(tmp_path)]) == 2
    assert "--cases does not apply" in capsys.readouterr().err
