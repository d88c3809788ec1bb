"""Sweep records and refusals (issue 30): a finished case shows no stale exit code of an
earlier interrupted attempt; a second sweep on a directory in use is refused; under a
plain mpirun the refusal is printed once, not once per rank."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from dpcollapse.cli import main
from dpcollapse.io.rundir import take_lock
from dpcollapse.sweep.collect import case_row, record_path, run_dir
from dpcollapse.sweep.spec import load_sweep
from tests.helpers import OVERSUBSCRIBE, ROOT, clean_env

RIGID = ROOT / "configs" / "rigid.yaml"


def _sweep(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(f"base: {RIGID}\ngrid: {{material.friction_angle: [25, 30]}}\n")
    return path


def test_a_finished_case_shows_no_stale_exit_code(tmp_path):
    sweep = load_sweep(_sweep(tmp_path))
    out, case = tmp_path / "out", sweep.cases[0]
    run_dir(out, case).mkdir(parents=True)
    (run_dir(out, case) / "run.json").write_text(json.dumps(
        {"status": "end_time", "config": case.config, "summary": {"t": 1.0}}))
    record_path(out, case).parent.mkdir(parents=True)
    record_path(out, case).write_text(json.dumps(
        {"case": case.name, "running": False, "exit_code": 130,
         "attempts": [{"action": "fresh", "exit_code": 130}]}))
    row = case_row(sweep, out, case)
    assert row["status"] == "end_time" and row["exit_code"] == ""


def test_a_second_sweep_on_a_directory_in_use_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    fd = take_lock(out, ".sweep.lock", "sweep")
    try:
        assert main(["sweep", str(_sweep(tmp_path)), "--out", str(out)]) == 2
    finally:
        os.close(fd)
    err = capsys.readouterr().err
    assert "in use by another sweep" in err and len(err.strip().splitlines()) == 1
    assert not (out / "runs").exists()


def test_the_refusal_under_mpirun_is_printed_once(tmp_path):
    env = clean_env()
    env.update(OVERSUBSCRIBE, PYTHONPATH=str(ROOT))
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "dpcollapse.cli", "sweep",
                           str(_sweep(tmp_path)), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=120)
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("dpcollapse: error:")]
    assert len(lines) == 1 and "runs as one process" in lines[0], proc.stderr
