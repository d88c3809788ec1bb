"""The exit-1 cases of issue 30 are bad input (exit 2) with one line: mesh --out without
.msh or unwritable, a 4.4 kB --out, plot of a damaged run directory, ladder --plot-only on
a garbage CSV, validate with a config that is not a periodic layer."""

from __future__ import annotations

import pytest

from dpcollapse.cli import main
from tests.helpers import ROOT
from tests.system.test_faults import _one_error_line, _run

RIGID = str(ROOT / "configs" / "rigid.yaml")


@pytest.mark.parametrize("out, words", [("mesh_without_extension", "must end in .msh"),
                                         ("/proc/x.msh", "cannot be written")])
def test_mesh_out_that_cannot_be_written_is_bad_input(tmp_path, capsys, out, words):
    target = out if out.startswith("/") else str(tmp_path / out)
    assert main(["mesh", RIGID, "--out", target]) == 2
    assert words in _one_error_line(capsys.readouterr().err)


def test_an_out_path_longer_than_the_system_allows_is_bad_input(tmp_path, capsys):
    out = tmp_path.joinpath(*["a" * 200] * 22)
    assert main(["run", RIGID, "--out", str(out), "--quiet"]) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "more than the file system allows" in line and len(line) < 300


def test_plot_of_a_damaged_run_directory_is_bad_input(tmp_path, capsys):
    out = tmp_path / "run"
    assert _run(out, end=0.004) == 0
    step = sorted((out / "fields").glob("step_*.h5"))[1]
    step.write_bytes(step.read_bytes()[:1000])
    capsys.readouterr()
    assert main(["plot", str(out)]) == 2
    assert f"{step.name} (/Mesh" in _one_error_line(capsys.readouterr().err)
    step.unlink()
    assert main(["plot", str(out)]) == 2
    assert "is missing" in _one_error_line(capsys.readouterr().err)
    master = out / "solution.xdmf"
    master.write_text(master.read_text()[:300])
    assert main(["plot", str(out)]) == 2
    assert "solution.xdmf is damaged" in _one_error_line(capsys.readouterr().err)


def test_ladder_plot_only_on_a_garbage_csv_is_bad_input(tmp_path, capsys):
    (tmp_path / "ladder.csv").write_text("garbage,,\n\x01 not a table\n")
    from studies.cli import main as studies_main

    assert studies_main(["ladder", "--plot-only", "--out", str(tmp_path)]) == 2
    assert "not a ladder table" in _one_error_line(capsys.readouterr().err)


def test_validate_with_a_collapse_config_is_refused_at_once(tmp_path, capsys):
    assert main(["validate", "plug", "--config", RIGID, "--out", str(tmp_path)]) == 2
    assert "needs a periodic layer" in _one_error_line(capsys.readouterr().err)


def test_an_interrupt_under_mpirun_says_how_to_read_mpiruns_status(monkeypatch, capsys):
    """Issue 47: SIGTERM to Open MPI's mpirun ends it with exit 1 even when the ranks stop
    cleanly with 130 (measured, docs/reliability.md); the line says run.json is the outcome.
    Serially the line is unchanged."""
    from dpcollapse import cli, parallel

    monkeypatch.setattr(cli, "end_together", lambda *a, **k: False)
    message = "stopped at t = 0.0235 s; the run directory is valid, continue with --resume"
    assert cli._fail(message, 130) == 130
    assert _one_error_line(capsys.readouterr().err) == f"dpcollapse: error: {message}"
    monkeypatch.setattr(parallel, "several_ranks", lambda: True)
    assert cli._fail(message, 130) == 130
    line = _one_error_line(capsys.readouterr().err)
    assert line.startswith(f"dpcollapse: error: {message}; under mpirun") and "run.json" in line
    assert cli._fail("mesh degenerate", 4) == 4                  # other statuses: unchanged
    assert _one_error_line(capsys.readouterr().err) == "dpcollapse: error: mesh degenerate"
