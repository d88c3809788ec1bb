"""The run directory is checked, not assumed (issue 47): a run directory removed or replaced
during a run ends the run with exit 5 and one line at the next write, not exit 0 with a
``run.json`` saying ``end_time`` and a ``solution.xdmf`` pointing at missing data."""

from __future__ import annotations

import shutil
import subprocess
import time

import pytest

from dpcollapse.errors import OutputError
from dpcollapse.io.presence import DirectoryPresence
from tests.helpers import ROOT, clean_env, dpcollapse_cmd

RIGID = str(ROOT / "configs" / "rigid.yaml")


def _says_removed(line: str) -> bool:
    """The line of a run whose directory was removed: the directory itself, its step files
    (fields/ goes first), or the file a write cut short was writing."""
    return ("removed during the run" in line) or ("No such file or directory" in line)


def _lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.strip()]


def _remove_once_fields_are_written(proc, out) -> str:
    """`rm -rf` ``out`` once the run ``proc`` wrote its second step's fields (retried: the
    removal races the run's writes into fields/); the run's stderr, which must come within
    60 s of the removal."""
    try:
        second_step = out / "fields" / "step_000001.h5"
        deadline = time.monotonic() + 300
        while not second_step.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before its directory could be removed"
        for _ in range(20):
            shutil.rmtree(out, ignore_errors=True)
            if not out.exists():
                break
        removed = time.monotonic()
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert time.monotonic() - removed < 60
    return err


def test_rm_rf_of_the_run_directory_during_a_run_is_exit_5_with_one_line(tmp_path):
    """`rm -rf` of the run directory once the first steps' fields are written (issue 47:
    at 4 s): the run ends within 60 s with exit 5 and one line, and nothing is made again
    in its place."""
    out = tmp_path / "run"
    proc = subprocess.Popen(
        dpcollapse_cmd() + ["run", RIGID, "--out", str(out), "--quiet",
                            "--set", "geometry.mesh_size=0.02", "--set", "time.end_time=0.5",
                            "--set", "time.output_every=1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=clean_env(), cwd=ROOT)
    err = _remove_once_fields_are_written(proc, out)
    assert proc.returncode == 5, err
    lines = _lines(err)
    assert len(lines) == 1 and "Traceback" not in err, err
    # the removal races the run's own writes: a write the removal cut short can fail first,
    # with the I/O error of the file it was writing (the same exit 5)
    assert str(out) in lines[0] and _says_removed(lines[0]), lines
    assert not out.exists()


def test_a_directory_removed_and_made_again_is_not_the_run_directory(tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    presence = DirectoryPresence(run_dir)
    presence.check("run.json")                           # still the one taken
    shutil.rmtree(run_dir)
    with pytest.raises(OutputError, match="was removed during the run .writing run.json"):
        presence.check("run.json")
    run_dir.mkdir()                                      # e.g. by HDF5 making parent folders
    with pytest.raises(OutputError, match="removed and made again"):
        presence.check("run.json")


def test_a_step_file_removed_during_a_run_stops_the_next_output(tmp_path):
    """The master never points at data that is not there: a published step's file removed
    by hand is exit 5 at the next output, and the master keeps its last whole state."""
    import xml.etree.ElementTree as ET

    import dolfinx
    from mpi4py import MPI

    from dpcollapse import compat
    from dpcollapse.io.xdmf import XDMFTimeSeries

    mesh = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (2, 2))
    u = dolfinx.fem.Function(compat.scalar_space(mesh, 1), name="u")
    series = XDMFTimeSeries(tmp_path, MPI.COMM_SELF)
    series.write(0.0, mesh, [u])
    series.write(0.1, mesh, [u])
    (tmp_path / "fields" / "step_000000.h5").unlink()
    with pytest.raises(OutputError, match="step file.* were removed during the run"):
        series.write(0.2, mesh, [u])
    times = [t.get("Value") for t in ET.parse(tmp_path / "solution.xdmf").getroot().iter("Time")]
    assert len(times) == 2
    assert not (tmp_path / "fields" / "step_000002.h5").exists()


def test_rm_rf_of_the_run_directory_under_mpirun_is_exit_5(tmp_path):
    """The same under `mpirun -n 2`: every rank ends with exit 5 within seconds, one line of
    ours (rank 0's or the failing rank's), no traceback, nothing made again."""
    from tests.system.test_mpi_faults import _mpirun, _our_lines

    out = tmp_path / "run"
    proc = _mpirun(tmp_path, "run", RIGID, "--out", out, "--quiet", "--set",
                   "geometry.mesh_size=0.02", "--set", "time.end_time=0.5", "--set",
                   "time.output_every=1", popen=True)
    err = _remove_once_fields_are_written(proc, out)
    assert proc.returncode == 5, err[-3000:]
    lines = _our_lines(err)
    assert len(lines) == 1 and _says_removed(lines[0]), err[-3000:]
    assert not out.exists()
