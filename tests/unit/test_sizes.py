"""Sizes refused at check time (issue 47): cells and memory estimated from the finest size a
run actually uses (the silo's orifice cells, the adaptive box's model.min_cell, the free
surface's cells), against the cell limit and the machine's memory, with the estimate in the
one-line message; `check` and `run` both refuse, serially and under mpirun -n 2, before
gmsh allocates anything."""

from __future__ import annotations

import re

import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.cli import main
from dpcollapse.config import load_config, sizes, with_overrides
from tests.helpers import ROOT

SILO = str(ROOT / "configs" / "silo.yaml")
HOPPER = str(ROOT / "configs" / "hopper.yaml")
ADAPTIVE = str(ROOT / "configs" / "column_eulerian_a6.26_adaptive.yaml")
RIGID = str(ROOT / "configs" / "rigid.yaml")

#: issue 47's cases: gmsh's std::bad_alloc (exit 134), MemoryError (exit 1) before
TOO_LARGE = [
    (SILO, ["geometry.mesh_size=1e-5"], "geometry.mesh_size = 1e-05"),
    (SILO, ["geometry.bin_height=1e5"], "geometry.bin_height = 100000"),
    (SILO, ["geometry.width=1e4"], "geometry.width = 10000"),
    (SILO, ["geometry.orifice_mesh_size=1e-9"], "geometry.orifice_mesh_size = 1e-09"),
    (HOPPER, ["geometry.orifice_mesh_size=1e-9"], "geometry.orifice_mesh_size = 1e-09"),
    (ADAPTIVE, ["model.min_cell=1e-6"], "model.min_cell = 1e-06"),
    # the uniform box at model.min_cell = max_cell, not at geometry.mesh_size
    (ADAPTIVE, ["model.min_cell=1e-5", "model.max_cell=1e-5"], "model.min_cell = 1e-05"),
    (RIGID, ["geometry.surface_mesh_size=1e-7"], "geometry.surface_mesh_size = 1e-07"),
]


def _line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("config, overrides, key", TOO_LARGE)
def test_a_mesh_too_large_is_refused_by_check_and_run_with_the_estimate(tmp_path, capsys, config,
                                                                        overrides, key):
    override = [a for item in overrides for a in ("--set", item)]
    assert main(["check", config, *override]) == 2
    line = _line(capsys)
    assert key in line and re.search(r"about [0-9.e+]+ cells of .* \(about [0-9.e+]+ GB\)", line)
    out = tmp_path / "run"
    assert main(["run", config, *override, "--out", str(out), "--quiet"]) == 2
    assert key in _line(capsys)
    assert not out.exists()                  # refused before anything was made


def test_an_orifice_of_1e_300_m_is_bad_input_naming_the_key_and_range(tmp_path, capsys):
    for extra in ([], ["--set", "geometry.orifice_mesh_size=1e-301"]):
        assert main(["run", SILO, "--set", "geometry.orifice_width=1e-300", *extra,
                     "--out", str(tmp_path / "run"), "--quiet"]) == 2
        assert "geometry.orifice_width = 1e-300: must be in [2.2e-08, 0.2) m" in _line(capsys)


def test_a_mesh_larger_than_the_machine_memory_is_refused(monkeypatch, capsys):
    """The machine's memory bounds the estimate too (here a machine of 1 MB: the rigid
    case's 1.45e3 cells take about 1.5 MB)."""
    monkeypatch.setattr(sizes, "machine_memory", lambda: 1.0e6)
    assert main(["check", RIGID]) == 2
    assert "more than this machine's 0.001 GB" in _line(capsys)
    monkeypatch.setattr(sizes, "machine_memory", lambda: 1.0e9)
    assert main(["check", RIGID]) == 0


def test_machine_memory_is_the_smaller_of_physical_and_cgroup_limit():
    memory = sizes.machine_memory()
    assert memory is not None and 1e8 < memory <= sizes.os.sysconf("SC_PHYS_PAGES") * \
        sizes.os.sysconf("SC_PAGE_SIZE")


@pytest.mark.parametrize("config, overrides", [
    (SILO, ["geometry.orifice_mesh_size=1e-4"]),
    (HOPPER, ["geometry.orifice_mesh_size=1e-4"]),
    (SILO, ["geometry.width=2.0", "geometry.orifice_mesh_size=1e-3", "geometry.mesh_size=0.02"]),
    (RIGID, ["geometry.surface_mesh_size=0.0005"]),
    (RIGID, ["geometry.mesh_size=0.003"]),
])
def test_the_estimate_follows_the_cells_gmsh_makes(config, overrides):
    """Measured 0.69 … 1.67 of gmsh's count (docs/benchmarks/2026-12-07-sizes.md); a factor
    of 2 either way is what the refusal may be off by."""
    from dpcollapse.scenes.registry import build_mesh

    cfg = with_overrides(load_config(config), overrides)
    made = compat.num_owned_cells(build_mesh(cfg, MPI.COMM_SELF).mesh)
    estimate = sizes.first_mesh(cfg).cells
    assert 0.5 < estimate / made < 2.0, (estimate, made)


@pytest.mark.mpi
def test_a_silo_too_large_is_refused_on_every_rank(tmp_path, capsys):
    """Under mpirun -n 2 (issue 47: gmsh's std::bad_alloc on rank 0, exit 134)."""
    out = tmp_path / "run"
    out = MPI.COMM_WORLD.bcast(out, root=0)
    assert main(["run", SILO, "--set", "geometry.mesh_size=1e-5", "--out", str(out),
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert "geometry.mesh_size = 1e-05" in err and "Traceback" not in err
    assert not out.exists()
