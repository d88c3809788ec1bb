"""A read-only output location (issue 47), made so with the immutable attribute (``chattr
+i``: refused even to root, whom permission bits do not stop): ``run --out`` is bad input
(exit 2, at the start, nothing run); ``plot``, ``plot-sweep`` and ``ladder --plot-only``,
whose input is valid and whose only write is their PNG at the end, are I/O failures
(exit 5, one line naming the file)."""

from __future__ import annotations

import shutil
import subprocess
from contextlib import contextmanager

import pytest

from dpcollapse.cli import main
from tests.helpers import ROOT
from tests.system.test_faults import _one_error_line, _run

FIGURES = ROOT / "docs" / "figures"
SWEEP_CSV = ("case,geometry.bed_angle,status,exit_code,front,runout,max_height,t_end,steps,"
             "mean_iterations,wall_time,process_time,error,run_dir\n"
             "bed_angle=0,0,end_time,0,0.297,3.6e-05,0.2499,0.005,5,5.4,0.47,6.2,,runs/bed_angle=0\n"
             "bed_angle=5,5,end_time,0,0.298,4.7e-05,0.2499,0.005,5,5.2,0.47,6.8,,runs/bed_angle=5\n")


@contextmanager
def read_only(folder):
    """``folder`` immutable for the block; the test is skipped where that cannot be done
    (not root, no chattr, a file system without the attribute)."""
    if shutil.which("chattr") is None:
        pytest.skip("no chattr")
    done = subprocess.run(["chattr", "+i", str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"chattr +i: {done.stderr.decode().strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=True)


def test_run_into_a_read_only_directory_is_bad_input(tmp_path, capsys):
    out = tmp_path / "ro"
    out.mkdir()
    with read_only(out):
        assert main(["run", str(ROOT / "configs" / "rigid.yaml"), "--out", str(out),
                     "--quiet"]) == 2
        assert "the run directory is not writable" in _one_error_line(capsys.readouterr().err)
        assert main(["run", str(ROOT / "configs" / "rigid.yaml"), "--out", str(out / "sub"),
                     "--quiet"]) == 2
        assert "cannot create the run directory" in _one_error_line(capsys.readouterr().err)


def test_plot_into_a_read_only_run_directory_is_an_io_failure(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out, end=0.004) == 0
    capsys.readouterr()
    with read_only(out):
        assert main(["plot", str(out)]) == 5
        line = _one_error_line(capsys.readouterr().err)
    assert line.startswith("dpcollapse: error: I/O failure: ") and str(out / "collapse.png") in line


def test_plot_sweep_into_a_read_only_folder_is_an_io_failure(tmp_path, capsys):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "sweep.csv").write_text(SWEEP_CSV)
    with read_only(sweep):
        assert main(["plot-sweep", str(sweep), "--x", "geometry.bed_angle"]) == 5
        line = _one_error_line(capsys.readouterr().err)
    assert "I/O failure" in line and str(sweep / "runout_vs_bed_angle.png") in line


def test_ladder_plot_only_into_a_read_only_folder_is_an_io_failure(tmp_path, capsys):
    from studies.cli import main as studies_main

    out = tmp_path / "out"
    out.mkdir()
    for name in ("ladder.csv", "ladder_series.csv"):
        shutil.copy(FIGURES / name, out / name)
    with read_only(out):
        assert studies_main(["ladder", "--plot-only", "--out", str(out)]) == 5
        line = _one_error_line(capsys.readouterr().err)
    assert "I/O failure" in line and str(out / "ladder.png") in line
    assert (out / "ladder.csv").read_bytes() == (FIGURES / "ladder.csv").read_bytes()
