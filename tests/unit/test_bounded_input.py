"""Bounded input (issue 30): config and sweep files over 1 MB, FIFOs and devices refused
before parsing; numbers finite and physical; grids capped (the estimate printed by
check); numerics keys a model does not read refused; a key twice in a sweep file refused."""

from __future__ import annotations

import os
import re
import threading

import pytest

from dpcollapse.cli import main
from tests.helpers import ROOT

RIGID = str(ROOT / "configs" / "rigid.yaml")
COLUMN_SH = str(ROOT / "configs" / "column_sh.yaml")
COLUMN_2P = str(ROOT / "configs" / "column_eulerian_a1.42.yaml")


def _line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("command", ["check", "sweep"])
def test_a_device_a_fifo_and_a_huge_file_are_refused_before_parsing(tmp_path, capsys, command):
    assert main([command, "/dev/zero"]) == 2
    assert "not a regular file" in _line(capsys)
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    done = threading.Event()
    threading.Thread(target=lambda: done.wait(10) or open(fifo, "w").close(), daemon=True).start()
    assert main([command, str(fifo)]) == 2          # did not block on the FIFO
    done.set()
    assert "not a regular file" in _line(capsys)
    big = tmp_path / "big.yaml"
    big.write_text("geometry:\n  height: 0.2\n" + "# padding\n" * 120_000)
    assert main([command, str(big)]) == 2
    assert "bytes, more than the 1000000" in _line(capsys)


def test_a_key_twice_in_a_sweep_file_is_refused(tmp_path, capsys):
    sweep = tmp_path / "s.yaml"
    sweep.write_text(f"base: {RIGID}\ngrid: {{material.friction_angle: [25, 30]}}\n"
                     "grid: {material.friction_angle: [20]}\n")
    assert main(["sweep", str(sweep), "--dry-run", "--out", str(tmp_path / "o")]) == 2
    assert "'grid' appears twice" in _line(capsys)


@pytest.mark.parametrize("config, overrides, key", [
    (RIGID, ["material.gravity=1e300"], "material.gravity"),
    (COLUMN_SH, ["model.x_min=.nan"], "model.x_min"),
    (COLUMN_SH, ["model.x_max=.inf"], "model.x_max"),
    (COLUMN_SH, ["model.n_cells=1e12"], "model.n_cells"),
    (COLUMN_SH, ["numerics.epsilon=0.1"], "numerics.epsilon"),
    (COLUMN_2P, ["numerics.method=augmented_lagrangian"], "numerics.method"),
    (COLUMN_2P, ["numerics.nonlinear_solver=newton"], "numerics.nonlinear_solver"),
    (COLUMN_2P, ["model.box_length=1e6"], "model.box_length"),
    (RIGID, ["geometry.mesh_size=1e-5"], "geometry.mesh_size"),
])
def test_unphysical_or_unused_values_are_refused(capsys, config, overrides, key):
    args = [a for item in overrides for a in ("--set", item)]
    assert main(["check", config, *args]) == 2
    assert key in _line(capsys)


@pytest.mark.parametrize("config", [COLUMN_2P, RIGID])
def test_check_prints_the_memory_estimate(capsys, config):
    assert main(["check", config]) == 0
    assert re.search(r"about [0-9.e+]+ cells .*\(about [0-9.e+]+ MB\)", capsys.readouterr().out)
