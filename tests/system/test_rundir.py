"""A run directory holds exactly one run (issue 13): a second run into it is refused, an
overwrite replaces it whole, a resume resumes or refuses, a lock refuses a second writer,
and unusable output locations are one line with exit 2."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest

from dpcollapse.cli import main
from dpcollapse.config import config_to_dict, load_config
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.io.rundir import RunDirectory, changed_keys
from tests.helpers import ROOT

RIGID = str(ROOT / "configs" / "rigid.yaml")
TINY = ["--set", "geometry.mesh_size=0.04", "--set", "time.output_every=2"]


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("dpcollapse: error: ")
    return lines[0]


def _run(out, *extra, end=0.004):
    return main(["run", RIGID, *TINY, "--set", f"time.end_time={end}", "--out", str(out),
                 "--quiet", *extra])


def _xdmf_times(run_dir):
    root = ET.parse(run_dir / "solution.xdmf").getroot()
    return [float(t.get("Value")) for t in root.iter("Time")]


def test_a_second_run_into_the_same_directory_is_refused(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out) == 0
    before = (out / "run.json").read_text(), (out / "diagnostics.csv").read_text()
    capsys.readouterr()
    assert _run(out, end=0.006) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "--resume" in line and "--overwrite" in line and "already holds a run" in line
    assert ((out / "run.json").read_text(), (out / "diagnostics.csv").read_text()) == before


def test_overwrite_replaces_the_old_run_whole(tmp_path):
    out = tmp_path / "run"
    assert _run(out, end=0.006) == 0
    assert _run(out, "--overwrite", "--set", "geometry.mesh_size=0.05", end=0.003) == 0
    d = read_diagnostics(out / "diagnostics.csv")
    assert d["t"][-1] == pytest.approx(0.003)
    assert max(_xdmf_times(out)) == pytest.approx(0.003)        # no step of the first run
    steps = sorted(p.name for p in (out / "fields").glob("step_*.h5"))
    assert len(steps) == len(_xdmf_times(out))
    info = json.loads((out / "run.json").read_text())
    assert info["config"]["geometry"]["mesh_size"] == 0.05 and "segments" not in info


def test_resume_without_checkpoint_is_refused(tmp_path, capsys):
    assert _run(tmp_path / "empty", "--resume") == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "no checkpoint" in line


def test_resume_with_a_changed_config_names_the_keys(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out, "--set", "time.checkpoint_every=1") == 0
    capsys.readouterr()
    assert _run(out, "--resume", "--set", "material.friction_angle=30",
                "--set", "geometry.height=0.3", end=0.006) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "geometry.height" in line and "material.friction_angle" in line
    assert "time.end_time" in line        # named among the keys that may change
    # only the end time changes: it resumes and continues
    assert _run(out, "--resume", "--set", "time.checkpoint_every=1", end=0.006) == 0
    assert read_diagnostics(out / "diagnostics.csv")["t"][-1] == pytest.approx(0.006)


def test_a_second_writer_is_refused_while_the_first_holds_the_lock(tmp_path, capsys):
    out = tmp_path / "run"
    cfg = config_to_dict(load_config(RIGID))
    first = RunDirectory(out)
    first.claim(cfg, "new")
    try:
        assert _run(out, "--overwrite") == 2
        line = _one_error_line(capsys.readouterr().err)
        assert "in use by another run" in line and "pid" in line
    finally:
        first.release()
    # released (as after a crash: the kernel drops the lock with its process): usable again
    assert (out / ".lock").exists()
    assert _run(out) == 0


@pytest.mark.parametrize("where, expected", [
    ("", "non-empty"),
    ("afile/run", "is a file"),
    ("x" * 300, "path component"),
])
def test_unusable_output_locations_are_one_line(tmp_path, monkeypatch, capsys, where, expected):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("not a directory")
    assert main(["run", RIGID, "--out", where, "--quiet"]) == 2
    assert expected in _one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]   # nothing written


def test_resume_and_overwrite_exclude_each_other(tmp_path, capsys):
    assert _run(tmp_path / "r", "--resume", "--overwrite") == 2
    assert "exclude" in _one_error_line(capsys.readouterr().err)


def test_changed_keys():
    old = {"time": {"end_time": 1.0, "dt": 1e-3}, "geometry": {"height": 0.25}}
    new = {"time": {"end_time": 2.0, "dt": 1e-3}, "geometry": {"height": 0.3}, "extra": {}}
    assert changed_keys(old, new) == ["extra", "geometry.height", "time.end_time"]
