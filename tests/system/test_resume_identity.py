"""A checkpoint knows its run, and a resume verifies what it continues (issue 30): a
checkpoint copied in from another run is refused naming both; an output step whose HDF5
file is truncated leaves the master; a diagnostics row the file lost is rebuilt from the
checkpoint; --out refuses shared folders; --overwrite removes only what a run wrote."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from dpcollapse.cli import main
from dpcollapse.io.diagnostics import complete_rows
from tests.helpers import ROOT
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
