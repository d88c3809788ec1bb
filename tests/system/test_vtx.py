"""ADIOS2 VTX output (``output.format: vtx|both``): where DOLFINx has ADIOS2 (Debian 13 and
later) the series follows the moving mesh through a remesh and ParaView's ADIOS2 VTX reader
opens it; where it has none (Debian 12's 0.5.2) the key is refused with one line."""

import json

import numpy as np
import pytest

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.simulation import Simulation
from tests.helpers import ROOT, paraview_summaries, run_cli

#: A coarse rigid-bed collapse that reaches its first remesh (≈ t = 0.096 s at 2 cm).
SHORT = ["geometry.mesh_size=0.02", "time.end_time=0.12", "time.output_every=30",
         "time.checkpoint_every=40"]


@pytest.mark.skipif(compat.has_adios2(), reason="this DOLFINx has ADIOS2: test_vtx_series runs")
def test_vtx_refused_without_adios2(tmp_path):
    proc = run_cli("run", "configs/rigid.yaml", "--set", "output.format=vtx", "--out",
                   tmp_path / "run", "--quiet")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "output.format = vtx" in lines[0] and "xdmf" in lines[0]
    assert "Traceback" not in proc.stderr


def test_bad_format_is_one_line():
    proc = run_cli("check", "configs/rigid.yaml", "--set", "output.format=vtk")
    assert proc.returncode == 2
    assert "output.format" in proc.stderr and "xdmf" in proc.stderr


@pytest.mark.skipif(not compat.has_adios2(), reason="DOLFINx built without ADIOS2 (0.5.2)")
def test_vtx_series_follows_the_moving_mesh_through_a_remesh(tmp_path):
    cfg = load_config(ROOT / "configs" / "rigid.yaml", SHORT + ["output.format=both"])
    summary = Simulation(cfg, tmp_path, quiet=True).run()
    assert summary["remeshes"] >= 1
    segments = json.loads((tmp_path / "vtx" / "segments.json").read_text())
    # one segment per mesh and per set of output functions (a landing makes new ones on the
    # same mesh: here at t = 0.12 s after the remesh at 0.096 s)
    assert len(segments) >= summary["remeshes"] + 1
    times = [t for s in segments for t in s["times"]]
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    assert times[0] == 0.0 and times[-1] == pytest.approx(d["t"][-1])
    masters = [tmp_path / "solution.xdmf"]
    for seg in segments:
        masters += [tmp_path / "vtx" / seg["files"]["nodes"], tmp_path / "vtx" / seg["files"]["cells"]]
    xdmf, *vtx = paraview_summaries(*masters)
    assert [t for pv in vtx[::2] for t in pv["times"]] == pytest.approx(xdmf["times"])
    first_nodes, first_cells = vtx[0], vtx[1]
    for name in ("velocity", "pressure", "flowing"):
        assert name in first_nodes["point_arrays"]
    assert "strain_rate" in first_cells["cell_arrays"]
    # same mesh and values as the XDMF at the same times
    assert first_nodes["first"]["num_cells"] == xdmf["first"]["num_cells"]
    assert first_nodes["last"]["bounds"] == pytest.approx(
        xdmf["snapshots"][len(first_nodes["times"]) - 1]["bounds"]
    )
    assert first_nodes["first"]["bounds"] != first_nodes["last"]["bounds"] or len(first_nodes["times"]) == 1
    last_nodes = vtx[-2]
    assert last_nodes["last"]["num_cells"] == xdmf["last"]["num_cells"]
    # the values at every output time are the XDMF's (a writer bound to functions that the
    # run had replaced repeated its segment's first values)
    snapshots = [snap for pv in vtx[::2] for snap in pv["snapshots"]]
    assert len(snapshots) == len(xdmf["snapshots"])
    for got, want in zip(snapshots, xdmf["snapshots"]):
        assert np.allclose(got["ranges"]["pressure"], want["ranges"]["pressure"], rtol=1e-9)
