"""The depth-averaged Savage–Hutter model through the time loop and the command line:
``dpcollapse run`` end to end (outputs, ParaView, plot), the same result as the NumPy core's
own ``simulate``, bad keys (exit 2, one line), a scheme failure (exit 3), an interrupt
(130) and ``--resume`` reproducing the uninterrupted run, and 2 MPI ranks agreeing with one."""

import json
import os
import signal

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.cli import main
from dpcollapse.config import load_config
from dpcollapse.errors import Interrupted
from dpcollapse.io.diagnostics import COLUMNS, read_diagnostics
from dpcollapse.loop import Events
from dpcollapse.models.savage_hutter.exact import mangeney_dam_break
from dpcollapse.models.savage_hutter.setup import setup_from_config
from dpcollapse.models.savage_hutter.solver import simulate
from dpcollapse.plot import read_cell_field, read_series
from tests.helpers import ROOT, paraview_summaries, pvpython, run_cli, simulation

COLUMN = ROOT / "configs" / "column_sh.yaml"
SLOPE = ROOT / "configs" / "dambreak_slope_sh.yaml"
#: a small, fast version of the column (200 cells, order 1)
SMALL = ["model.n_cells=200", "model.order=1", "time.output_every=10", "time.checkpoint_every=10"]


def _final_profile(run_dir):
    """(cell centres, h) of the last output time, from solution.xdmf."""
    t, h = read_cell_field(run_dir, "thickness")[-1]
    _, x, cells = read_series(run_dir)[-1]
    centres = x[cells, 0].mean(axis=1)
    order = np.argsort(centres)
    return t, centres[order], h[order]


def test_run_end_to_end_matches_the_core_and_writes_the_2d_outputs(tmp_path):
    out = tmp_path / "run"
    proc = run_cli("run", COLUMN, "--out", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    info = json.loads((out / "run.json").read_text())
    s = info["summary"]
    assert info["status"] == "at_rest" and s["model"] == "savage_hutter"
    # the loop takes the core's steps: the same deposit, bit for bit, and one more step
    # (the step that finds the exact rest state, which the core does not count)
    setup = setup_from_config(load_config(COLUMN))
    core = simulate(setup.model, setup.grid, setup.h0, [2.0])
    assert core.rest_time is not None and s["steps"] == core.steps + 1
    assert s["front"] == core.front[-1] and s["max_height"] == core.max_height[-1]
    assert abs(s["area_drift"]) < 1e-13 and s["kinetic_energy"] == 0.0
    t, x, h = _final_profile(out)
    np.testing.assert_array_equal(h, core.h[-1])
    assert np.allclose(x, setup.grid.centers, atol=1e-12)
    # diagnostics: the loop's columns, then its own (no 2D mesh quality: no NaN columns)
    d = read_diagnostics(out / "diagnostics.csv")
    assert list(d) == COLUMNS + ["wet_front", "outflow"]
    assert len(d["t"]) == s["steps"] and np.all(np.diff(d["t"]) > 0)
    assert "min_angle" not in d and "min_angle" not in s
    assert max(d["courant"]) <= 1.0 + 1e-12  # the hard bound: CFL 1 and h >= 0
    # dpcollapse plot: profiles and the front against time
    assert run_cli("plot", out).returncode == 0
    assert (out / "collapse.png").stat().st_size > 10_000


@pytest.mark.skipif(pvpython() is None, reason="pvpython not installed")
def test_paraview_opens_the_profiles(tmp_path):
    sim = simulation(COLUMN, SMALL + ["time.end_time=0.05"], tmp_path, comm=MPI.COMM_SELF)
    sim.run()
    summary = paraview_summaries(tmp_path / "solution.xdmf")[0]
    assert {"thickness", "velocity"} <= set(summary["cell_arrays"])
    assert len(summary["times"]) >= 2
    first, last = summary["first"], summary["last"]
    assert last["num_cells"] == 200 and last["num_points"] == 201
    assert last["bounds"][:2] == pytest.approx([0.0, 1.0]) and last["bounds"][2:4] == [0.0, 0.0]
    assert first["ranges"]["thickness"] == pytest.approx([0.0, 0.14], abs=1e-12)
    assert first["ranges"]["velocity"] == [0.0, 0.0] and last["ranges"]["velocity"][1] > 0.5


def test_mangeney_dam_break_through_the_loop(tmp_path):
    """configs/dambreak_slope_sh.yaml at 600 cells, order 2: the profile at t = 5 s against the
    exact solution from 12 m behind the dam (beyond the wall's rarefaction) to the tip."""
    sim = simulation(SLOPE, ["model.n_cells=600", "time.output_every=1000"], tmp_path,
                     comm=MPI.COMM_SELF)
    s = sim.run()
    assert s["status"] == "end_time" and s["t"] == 5.0
    t, x, h = _final_profile(tmp_path)
    exact, _ = mangeney_dam_break(x - 40.0, t, 1.0, 22.0, 21.0)
    near = x > 40.0 - 12.0
    l1 = float(np.sum(np.abs(h - exact)[near]) * (x[1] - x[0]))
    # the core's validation at Δx = 0.15 and 0.075 m (order 2): 0.120 and 0.047 m²
    assert 0.03 < l1 < 0.12, l1
    assert abs(s["area_drift"]) < 1e-13


@pytest.mark.parametrize("override, message", [
    ("model.order=3", "model.order = 3: must be one of 1 or 2"),
    ("model.cfl=1.5", "model.cfl = 1.5: must be in (0, 1]"),
    ("model.shape_factor=2", "model.shape_factor = 2: must be in [1, 1.5]"),
    ("model.n_cells=1", "model.n_cells = 1: must be in [2, 1e+06]"),
    ("model.epsilon=1", "model.epsilon: unknown key"),
    ("model.left=periodic", "model.left = 'periodic': must be one of 'wall' or 'open'"),
    ("model.x_max=0.1", "the 1D domain must contain the mass"),
    ("geometry.shape=layer", "geometry.shape = 'layer': not available with model.name = savage_hutter"),
    ("initial.velocity=half_poiseuille", "initial.velocity = 'half_poiseuille': must be 'rest'"),
])
def test_bad_keys_are_one_line_exit_2(override, message, capsys):
    assert main(["check", str(COLUMN), "--set", override]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_model_key_under_the_other_model_names_it(capsys):
    assert main(["check", str(ROOT / "configs" / "rigid.yaml"), "--set", "model.cfl=0.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert "model.cfl: unknown key; it belongs to model.name = savage_hutter" in err


def test_run_with_a_bad_key_exits_2_with_one_line(tmp_path):
    proc = run_cli("run", COLUMN, "--out", tmp_path / "r", "--set", "model.order=3")
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "model.order" in lines[0]


def test_a_failing_scheme_exits_3(tmp_path, monkeypatch, capsys):
    import dpcollapse.models.savage_hutter.adapter as adapter

    def broken(h, q, terms, phys, dx, dt):
        return h, np.full_like(q, np.nan)

    monkeypatch.setattr(adapter, "update", broken)
    out = tmp_path / "r"
    args = ["run", str(COLUMN), "--out", str(out), "--quiet"] + sum([["--set", o] for o in SMALL], [])
    assert main(args) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "non-finite" in err[0]
    assert json.loads((out / "run.json").read_text())["status"] == "failed"


def test_interrupt_then_resume_reproduces_the_uninterrupted_run(tmp_path):
    """SIGINT during the loop: the step is finished, saved, Interrupted (exit 130); --resume
    ends with the same state, bit for bit, as a run never interrupted."""
    over = SMALL + ["time.end_time=0.3"]
    full = simulation(COLUMN, over, tmp_path / "full", comm=MPI.COMM_SELF).run()
    events = Events()
    events.subscribe(
        "step_accepted", lambda sim, row: row["step"] == 37 and os.kill(os.getpid(), signal.SIGINT)
    )
    split = tmp_path / "split"
    with pytest.raises(Interrupted) as stop:
        simulation(COLUMN, over, split, comm=MPI.COMM_SELF, events=events).run()
    assert stop.value.exit_code == 130
    assert json.loads((split / "run.json").read_text())["status"] == "interrupted"
    assert read_diagnostics(split / "diagnostics.csv")["step"][-1] == 37
    resumed = simulation(COLUMN, over, split, comm=MPI.COMM_SELF, resume=True).run()
    for key in ("status", "t", "steps", "front", "max_height", "kinetic_energy", "area", "wet_front"):
        assert resumed[key] == full[key], key
    a, b = (
        read_diagnostics(tmp_path / "full" / "diagnostics.csv"),
        read_diagnostics(split / "diagnostics.csv"),
    )
    for key in ("t", "dt", "front", "max_height", "kinetic_energy", "max_speed"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    np.testing.assert_array_equal(_final_profile(tmp_path / "full")[2], _final_profile(split)[2])


def test_resume_refuses_another_grid(tmp_path, capsys):
    out = tmp_path / "r"
    args = ["run", str(COLUMN), "--out", str(out), "--quiet"] + sum([["--set", o] for o in SMALL], [])
    assert main(args + ["--set", "time.end_time=0.02"]) == 0
    assert main(args + ["--set", "time.end_time=0.04", "--set", "model.n_cells=300", "--resume"]) == 2
    assert "n_cells" in capsys.readouterr().err


@pytest.mark.mpi
def test_two_ranks_agree_with_one(shared_tmp, comm, tmp_path):
    """Under mpirun every rank steps the same arrays: 2 ranks give the serial run exactly;
    the output mesh is split between the ranks and solution.xdmf holds every cell."""
    over = SMALL + ["time.end_time=0.1"]
    parallel = simulation(COLUMN, over, shared_tmp / "par", comm=comm).run()
    serial = simulation(COLUMN, over, tmp_path / f"ser{comm.rank}", comm=MPI.COMM_SELF).run()
    for key in ("steps", "t", "front", "max_height", "kinetic_energy", "area"):
        assert parallel[key] == serial[key], key
    assert comm.allgather(parallel["steps"]) == [parallel["steps"]] * comm.size
    if comm.rank == 0:
        np.testing.assert_array_equal(_final_profile(shared_tmp / "par")[2],
                                      _final_profile(tmp_path / "ser0")[2])


@pytest.mark.mpi
def test_a_failure_stops_every_rank_alike(shared_tmp, comm, monkeypatch):
    """A non-finite state appears on every rank at the same step (they step the same
    arrays): each raises the same ConvergenceError (exit 3), none waits for another."""
    import dpcollapse.models.savage_hutter.adapter as adapter
    from dpcollapse.errors import ConvergenceError

    real = adapter.update
    calls = []

    def breaks_at_step_5(h, q, terms, phys, dx, dt):
        calls.append(1)
        h, q = real(h, q, terms, phys, dx, dt)
        return (h, np.full_like(q, np.inf)) if len(calls) == 5 else (h, q)

    monkeypatch.setattr(adapter, "update", breaks_at_step_5)
    with pytest.raises(ConvergenceError) as failure:
        simulation(COLUMN, SMALL, shared_tmp / "fail", comm=comm).run()
    messages = comm.allgather(str(failure.value))
    assert len(set(messages)) == 1 and failure.value.exit_code == 3


def test_mesh_command_refuses_the_1d_model(capsys):
    assert main(["mesh", str(COLUMN)]) == 2
    assert "model.name = savage_hutter" in capsys.readouterr().err
