"""A checkpoint knows its run, and a resume verifies what it continues (issue 30): a
checkpoint copied in from another run is refused naming both; an output step whose HDF5
file is truncated leaves the master; a diagnostics row the file lost is rebuilt from the
checkpoint; --out refuses shared folders; --overwrite removes only what a run wrote."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from dpcollapse.cli import main
from dpcollapse.io.diagnostics import complete_rows, read_diagnostics
from tests.helpers import RIGID_BDF1, ROOT, simulation
from tests.system.test_faults import _one_error_line, _run, assert_whole

RIGID = str(ROOT / "configs" / "rigid.yaml")


def test_a_checkpoint_of_another_run_is_refused_naming_both(tmp_path, capsys):
    mine, other = tmp_path / "mine", tmp_path / "other"
    assert _run(mine, end=0.004) == 0
    assert _run(other, "--set", "geometry.height=0.2", end=0.004) == 0
    for name in ("checkpoint.npz", "checkpoint.prev.npz"):
        shutil.copy(other / name, mine / name)
    capsys.readouterr()
    assert _run(mine, "--resume", end=0.006) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "belongs to another run" in line and line.count("fingerprint") == 2
    run_id = json.loads((mine / "run.json").read_text())["run_id"]
    assert run_id and run_id in line


def test_a_checkpoint_of_a_run_with_the_same_config_is_refused(tmp_path, capsys):
    mine, twin = tmp_path / "mine", tmp_path / "twin"
    assert _run(mine, end=0.004) == 0
    assert _run(twin, end=0.004) == 0
    shutil.copy(twin / "checkpoint.npz", mine / "checkpoint.npz")
    capsys.readouterr()
    assert _run(mine, "--resume", end=0.006) == 2
    assert "belongs to another run" in _one_error_line(capsys.readouterr().err)


def test_a_run_of_a_program_older_than_a_key_resumes(tmp_path, monkeypatch):
    """A program older than a config key wrote config.yaml and fingerprinted its config
    without it (simulated: output.format dropped from both); this program, whose config has
    the key at the value the older one ran with, resumes the run."""
    import yaml

    import dpcollapse.simulation as simulation
    from dpcollapse import fingerprint
    from dpcollapse.config import config_to_dict

    def older(cfg):
        data = config_to_dict(cfg)
        del data["output"]["format"]
        return fingerprint._fingerprint(data)

    out = tmp_path / "run"
    with monkeypatch.context() as patch:
        patch.setattr(simulation, "config_fingerprint", older)
        assert _run(out, end=0.004) == 0
    saved = yaml.safe_load((out / "config.yaml").read_text())
    del saved["output"]["format"]
    (out / "config.yaml").write_text(yaml.safe_dump(saved, sort_keys=False))
    assert _run(out, "--resume", end=0.006) == 0
    assert json.loads((out / "run.json").read_text())["summary"]["steps"] == 6
    assert_whole(out)


def test_resume_drops_a_truncated_step_and_rebuilds_the_lost_csv_row(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out, end=0.006) == 0             # checkpoints at steps 2, 4, 6
    step = sorted((out / "fields").glob("step_*.h5"))[2]
    step.write_bytes(step.read_bytes()[:2000])   # truncated by a crash
    csv = out / "diagnostics.csv"
    csv.write_text(csv.read_text()[:-30])         # the last row (the checkpoint's) cut
    capsys.readouterr()
    assert _run(out, "--resume", end=0.008) == 0
    err = capsys.readouterr().err
    assert f"{step.name} cannot be read" in err and "dropped" in err
    assert "its row was rebuilt" in err
    assert step.name not in (out / "solution.xdmf").read_text()
    rows = complete_rows(csv)
    assert [int(r["step"]) for r in rows] == list(range(1, 9))
    assert_whole(out)


def test_out_refuses_the_root_home_and_working_directory(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    monkeypatch.chdir(tmp_path)
    for out, what in (("/", "root"), (str(tmp_path / "home"), "home"), (".", "working"),
                      (str(tmp_path), "working")):
        assert main(["run", RIGID, "--out", out, "--quiet"]) == 2
        line = _one_error_line(capsys.readouterr().err)
        assert f"the {what} directory" in line, line
    assert os.listdir(tmp_path / "home") == []


def test_overwrite_leaves_foreign_files_in_fields(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out, end=0.002) == 0
    mine = Path(out / "fields" / "notes.txt")
    mine.write_text("keep me")
    assert _run(out, "--overwrite", end=0.002) == 0
    assert mine.read_text() == "keep me"
    assert_whole(out)


#: the rigid collapse on 3 cm cells, written rarely (the stop writes its own checkpoint)
_COARSE = ["geometry.mesh_size=0.03", "time.output_every=1000", "time.checkpoint_every=1000"]
#: the a = 0.5 two-phase column on 1 cm cells; the same on the interface-adaptive box
_TWO_PHASE = ["geometry.mesh_size=0.01", "time.output_every=1000", "time.checkpoint_every=1000"]
_ADAPTIVE = ["model.box_height=0.06", "time.dt=2e-3", "model.min_cell=0.01", "model.max_cell=0.04",
             "time.output_every=1000", "time.checkpoint_every=1000"]
#: (config, overrides, the step after which the run is stopped) per option of the time
#: scheme. The error-controlled BDF2 (test_time_scheme), the two-phase column without
#: extrapolation (test_two_phase_run) and Savage–Hutter (test_savage_hutter_run) have their own.
RESUME_CASES = {
    "bdf1": ("rigid.yaml", [*_COARSE, *RIGID_BDF1, "time.end_time=0.02"], 8),
    "bdf1_extrapolate": ("rigid.yaml", [*_COARSE, *RIGID_BDF1, "time.end_time=0.02",
                                        "numerics.extrapolate=true"], 8),
    "bdf1_adaptive_step": ("rigid.yaml", [*_COARSE, *RIGID_BDF1, "time.end_time=0.03",
                                          "time.adaptive=true"], 8),
    "bdf2_fixed_step": ("rigid.yaml", [*_COARSE, "time.scheme=bdf2", "time.tolerance=null",
                                       "time.end_time=0.02"], 8),
    "newton": ("rigid.yaml", [*_COARSE, *RIGID_BDF1, "time.end_time=0.01",
                              "numerics.nonlinear_solver=newton"], 5),
    "augmented_lagrangian": ("rigid.yaml", [*_COARSE, *RIGID_BDF1, "time.end_time=0.012",
                                            "numerics.method=augmented_lagrangian"], 6),
    "two_phase_extrapolate": ("column_eulerian_a0.5.yaml", [*_TWO_PHASE, "time.end_time=0.03",
                                                            "numerics.extrapolate=true"], 10),
    "two_phase_adaptive_extrapolate": ("column_eulerian_a0.5.yaml", [
        *_ADAPTIVE, "time.end_time=0.04", "numerics.extrapolate=true",
        "numerics.fixed_iterations=1", "model.remesh_every=15"], 10),   # rebuilt at step 15
}


@pytest.mark.parametrize("case", list(RESUME_CASES))
def test_a_resumed_run_repeats_the_uninterrupted_one(case, tmp_path):
    """Stopped after step k and resumed, a run takes the uninterrupted run's steps: Δt, max
    speed, front and kinetic energy of every later step agree to 1e-12 (measured ≤ 1e-13;
    the mesh is renumbered on reading, so the assembly's round-off differs). Before
    2026-12-07 the checkpoint lost numerics.extrapolate's x_{n−1} (first resumed step 1e-4
    off in max speed) and the augmented Lagrangian's DG multipliers were read 1e-6 into
    their cell (5e-7)."""
    from mpi4py import MPI

    config, over, k = RESUME_CASES[case]
    full = simulation(config, over, tmp_path / "full", comm=MPI.COMM_SELF).run()
    split = simulation(config, over, tmp_path / "split", comm=MPI.COMM_SELF)
    assert split.run(observers=[lambda s: s.state.step == k])["status"] == "stopped_by_observer"
    resumed = simulation(config, over, tmp_path / "split", comm=MPI.COMM_SELF, resume=True).run()
    assert resumed["steps"] == full["steps"] > k + 2
    a = read_diagnostics(tmp_path / "full" / "diagnostics.csv")
    b = read_diagnostics(tmp_path / "split" / "diagnostics.csv")
    assert b["step"] == a["step"]
    for key in ("dt", "max_speed", "front", "kinetic_energy"):
        np.testing.assert_allclose(b[key][k:], a[key][k:], rtol=1e-12, atol=0, err_msg=key)


def test_a_checkpoint_without_the_extrapolation_history_says_so(tmp_path, caplog):
    """A checkpoint of an older version (no numerics.extrapolate history: simulated by
    removing it) resumes, says in one log line and in run.json's "resume" that its steps
    differ from the uninterrupted run's; a whole one says it is exact."""
    import logging

    from mpi4py import MPI

    config, over, k = RESUME_CASES["bdf1_extrapolate"]
    out = tmp_path / "run"
    assert simulation(config, over, out, comm=MPI.COMM_SELF).run(
        observers=[lambda s: s.state.step == k])["status"] == "stopped_by_observer"
    whole = dict(np.load(out / "checkpoint.npz"))
    simulation(config, over, out, comm=MPI.COMM_SELF, resume=True)
    assert json.loads((out / "run.json").read_text())["resume"] == {
        "t": pytest.approx(k * 1e-3), "step": k, "exact": True, "not_restored": []}
    state = json.loads(str(whole["state"]))
    del state["extrapolation"]
    np.savez(out / "checkpoint.npz", **{**whole, "state": np.array(json.dumps(state))})
    with caplog.at_level(logging.WARNING, logger="dpcollapse"):
        simulation(config, over, out, comm=MPI.COMM_SELF, resume=True).run()
    lines = [r.getMessage() for r in caplog.records if "checkpoint lacks" in r.getMessage()]
    assert len(lines) == 1 and "numerics.extrapolate" in lines[0]
    resume = json.loads((out / "run.json").read_text())["resume"]
    assert resume["exact"] is False and "numerics.extrapolate" in resume["not_restored"][0]


@pytest.mark.mpi
@pytest.mark.parametrize("case", ["bdf1_extrapolate", "two_phase_extrapolate"])
def test_a_resumed_run_on_all_ranks_repeats_the_uninterrupted_one(case, shared_tmp, comm):
    """The extrapolation history is stored cell by cell on the global mesh, as u and p are:
    on 2 ranks too a resumed run takes the uninterrupted (2-rank) run's steps to 1e-12."""
    config, over, k = RESUME_CASES[case]
    full = simulation(config, over, shared_tmp / "full", comm=comm).run()
    split = simulation(config, over, shared_tmp / "split", comm=comm)
    split.run(observers=[lambda s: s.state.step == k])
    resumed = simulation(config, over, shared_tmp / "split", comm=comm, resume=True).run()
    assert resumed["steps"] == full["steps"]
    if comm.rank == 0:
        a = read_diagnostics(shared_tmp / "full" / "diagnostics.csv")
        b = read_diagnostics(shared_tmp / "split" / "diagnostics.csv")
        for key in ("dt", "max_speed", "front", "kinetic_energy"):
            np.testing.assert_allclose(b[key][k:], a[key][k:], rtol=1e-12, atol=0, err_msg=key)
