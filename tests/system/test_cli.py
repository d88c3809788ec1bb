"""dpcollapse.cli: exit statuses and one-line errors on stderr."""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import pytest

from dpcollapse.cli import main
from dpcollapse.errors import ConvergenceError

ROOT = Path(__file__).resolve().parents[2]
RIGID = str(ROOT / "configs" / "rigid.yaml")


def _one_line(err: str) -> str:
    lines = err.strip("\n").splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("dpcollapse: error: ")
    return lines[0]


@pytest.fixture
def fake_module(monkeypatch):
    """Install a stand-in module recording its calls; returns the list of calls."""
    calls: list[tuple[str, tuple, dict]] = []

    def install(module: str, name: str, exc: Exception | None = None) -> list:
        def fn(*args, **kwargs):
            calls.append((name, args, kwargs))
            if exc is not None:
                raise exc

        monkeypatch.setitem(sys.modules, module, types.SimpleNamespace(**{name: fn}))
        return calls

    return install


def test_check_ok(capsys):
    assert main(["check", RIGID]) == 0
    out = capsys.readouterr().out
    assert "0.4770" in out and "0.0629" in out and "2000" in out


def test_check_adaptive(capsys):
    assert main(["check", RIGID, "--set", "time.scheme=bdf1", "--set", "time.tolerance=null",
                 "--set", "time.adaptive=true", "--set", "time.dt_max=2e-3"]) == 0
    assert "adaptive dt from 0.001 s up to 0.002 s" in capsys.readouterr().out


def test_check_bad_config(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("material:\n  density: -3.0\n")
    assert main(["check", str(bad)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "material.density" in line and "-3.0" in line


def test_check_unknown_key(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("time:\n  dtt: 0.1\n")
    assert main(["check", str(bad)]) == 2
    assert "time.dtt: unknown key; did you mean 'dt'?" in _one_line(capsys.readouterr().err)


def test_set_validated(capsys):
    assert main(["check", RIGID, "--set", "material.density=-1"]) == 2
    assert "material.density = -1" in _one_line(capsys.readouterr().err)


def test_set_malformed(capsys):
    assert main(["check", RIGID, "--set", "density"]) == 2
    assert "section.key=value" in _one_line(capsys.readouterr().err)


def test_missing_config(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.yaml")]) == 2
    assert "not found" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize("argv", [["frobnicate"], ["check"], ["check", RIGID, "--bogus"],
                                  ["run"], ["plot"]])
def test_usage_errors(argv, capsys):
    assert main(argv) == 2
    _one_line(capsys.readouterr().err)


def test_plot_missing_dir(tmp_path, capsys):
    assert main(["plot", str(tmp_path / "nope")]) == 2
    assert "does not exist" in _one_line(capsys.readouterr().err)


def test_help_and_version(capsys):
    assert main(["--help"]) == 0
    assert "check" in capsys.readouterr().out
    assert main(["--version"]) == 0
    assert "0.1.0" in capsys.readouterr().out


def test_run_calls_simulation(fake_module, tmp_path):
    calls = fake_module("dpcollapse.simulation", "run_simulation")
    assert main(["run", RIGID, "--set", "time.end_time=0.1", "--out", str(tmp_path / "r"),
                 "--quiet"]) == 0
    (name, args, kwargs), = calls
    assert args[0].time.end_time == 0.1
    assert kwargs == {"run_dir": tmp_path / "r", "quiet": True, "resume": False}


def test_run_resume_calls_simulation(fake_module, tmp_path):
    """--resume of a run with a checkpoint and the same config (end time may change)."""
    from dpcollapse.config import load_config, save_config

    run_dir = tmp_path / "r"
    save_config(load_config(RIGID, ["time.end_time=0.05"]), run_dir / "config.yaml")
    (run_dir / "checkpoint.npz").write_bytes(b"")
    calls = fake_module("dpcollapse.simulation", "run_simulation")
    assert main(["run", RIGID, "--set", "time.end_time=0.1", "--out", str(run_dir),
                 "--quiet", "--resume"]) == 0
    assert calls[0][2] == {"run_dir": run_dir, "quiet": True, "resume": True}


def test_run_default_dir(fake_module, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    calls = fake_module("dpcollapse.simulation", "run_simulation")
    assert main(["run", RIGID]) == 0
    assert calls[0][2] == {"run_dir": Path("runs/rigid"), "quiet": False, "resume": False}


def test_run_error_exit_code(fake_module, capsys, tmp_path):
    fake_module("dpcollapse.simulation", "run_simulation",
                ConvergenceError("no convergence at t = 0.1 s with dt = 1e-6 s"))
    assert main(["run", RIGID, "--out", str(tmp_path / "r")]) == 3
    assert "no convergence" in _one_line(capsys.readouterr().err)


def test_run_interrupted(fake_module, capsys, tmp_path):
    fake_module("dpcollapse.simulation", "run_simulation", KeyboardInterrupt())
    assert main(["run", RIGID, "--out", str(tmp_path / "r")]) == 130
    _one_line(capsys.readouterr().err)


def test_mesh_default_out(fake_module):
    calls = fake_module("dpcollapse.scenes.registry", "write_msh")
    assert main(["mesh", RIGID]) == 0
    assert calls[0][1][1] == Path("meshes/rigid.msh")


def test_plot_times(fake_module, tmp_path, capsys):
    calls = fake_module("dpcollapse.plot", "plot_run")
    assert main(["plot", str(tmp_path), "--times", "0,0.1,0.2"]) == 0
    assert calls[0][1] == (tmp_path,) and calls[0][2] == {"times": [0.0, 0.1, 0.2]}
    assert main(["plot", str(tmp_path)]) == 0
    assert calls[1][2] == {"times": None}
    assert main(["plot", str(tmp_path), "--times", "0,x"]) == 2
    _one_line(capsys.readouterr().err)


def test_console_script_bad_config(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("geometry:\n  flank_angle: 95.0\n")
    script = Path(sys.executable).parent / "dpcollapse"
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "dpcollapse.cli"]
    proc = subprocess.run(cmd + ["check", str(bad)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    line = _one_line(proc.stderr)
    assert "geometry.flank_angle = 95.0: must be in (0, 90] degrees" in line


def test_module_entry_point(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "dpcollapse.cli", "check", RIGID],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert "valid" in proc.stdout


@pytest.mark.parametrize("config", ["column_sh.yaml", "column_eulerian_a1.42.yaml"])
def test_mesh_of_a_model_without_a_scene_mesh_is_bad_input(tmp_path, capsys, config):
    """Was exit 1 (AttributeError: no model.n_cells) for the two-phase model."""
    assert main(["mesh", str(ROOT / "configs" / config), "--out", str(tmp_path / "m.msh")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "dpcollapse mesh needs model.name = stokes" in err[0]
    assert not (tmp_path / "m.msh").exists()
