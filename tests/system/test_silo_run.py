"""A tiny silo discharges through its orifice (issue 28): material leaves, and the material
in the bin plus the material that left is the initial material (to round-off)."""

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import paraview_summaries, simulation

#: a 6 cm bin filled to 5 cm, a 2 cm orifice, 5 mm cells (2.5 mm at the orifice), 40 ms
TINY = ["geometry.width=0.06", "geometry.fill_height=0.05", "geometry.bin_height=0.06",
        "geometry.orifice_width=0.02", "geometry.mesh_size=0.005",
        "geometry.orifice_mesh_size=0.0025", "time.end_time=0.04", "time.output_every=100",
        "time.checkpoint_every=100"]


def test_paraview_opens_a_silo_run(tmp_path, monkeypatch):
    """The silo's output opens in ParaView (Xdmf3ReaderT): c and the velocity at every output
    time, on the half bin [0, W/2] × [0, bin height]; ``dpcollapse plot`` draws the discharge
    panel the model declared (run.json's ``history_plot``)."""
    from dpcollapse import plot

    over = TINY + ["time.end_time=0.02", "time.output_every=10"]
    summary = simulation("silo.yaml", over, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    pv, = paraview_summaries(tmp_path / "solution.xdmf")
    assert len(pv["times"]) == 3                                   # t = 0, 0.01, 0.02
    assert "volume_fraction" in pv["cell_arrays"] and "velocity" in pv["point_arrays"]
    xmin, xmax, ymin, ymax = pv["last"]["bounds"][:4]
    assert (xmin, xmax, ymin, ymax) == pytest.approx((0.0, 0.03, 0.0, 0.06), abs=1e-9)
    drawn = []
    monkeypatch.setitem(plot.HISTORY_PLOTS, "discharge", lambda ax, d: drawn.append(sorted(d)))
    assert plot.plot_run(tmp_path).exists()
    assert drawn and "discharge_rate" in drawn[0]


def test_tiny_silo_discharges_and_conserves_its_material(tmp_path):
    summary = simulation("silo.yaml", TINY, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    columns = read_diagnostics(tmp_path / "diagnostics.csv")
    assert summary["outflow_area"] > 1e-6                  # material has left
    assert max(columns["discharge_rate"]) > 0.5            # kg/(m s) through the orifice
    initial = columns["area"][0] + columns["outflow_area"][0]
    total = np.asarray(columns["area"]) + np.asarray(columns["outflow_area"])
    assert np.max(np.abs(total - initial)) < 1e-9 * initial  # in the bin + out = initial
    assert abs(summary["area_drift"]) < 1e-6
    # the bin's mass falls as the integral of Q: −Δm ≈ Σ Q Δt (2 ρ_s × the half domain)
    dt, q = np.asarray(columns["dt"]), np.asarray(columns["discharge_rate"])
    lost = columns["bin_mass"][0] - columns["bin_mass"][-1]
    assert abs(lost - float(np.sum(q[1:] * dt[1:]))) < 1e-6 * columns["bin_mass"][0]


def test_a_bin_that_has_discharged_ends_emptied(tmp_path):
    """With geometry.empty_fraction = 0.99 the run ends (status emptied, not a failure) as
    soon as 1 % of the material has left, before the end time."""
    summary = simulation("silo.yaml", TINY + ["geometry.empty_fraction=0.99"], tmp_path,
                         comm=MPI.COMM_SELF).run()
    assert summary["status"] == "emptied" and summary["t"] < 0.04
    assert summary["outflow_area"] > 0.01 * summary["area"]
    assert abs(summary["area_drift"]) < 1e-6
    assert summary["discharge_steady"] > 0


def test_resume_keeps_the_outflow(tmp_path):
    """Stopped at 20 ms and resumed to 40 ms: the outflow total and the steady Q are those
    of the uninterrupted run (the checkpoint keeps them)."""
    short = [o for o in TINY if not o.startswith("time.end_time")]
    whole = simulation("silo.yaml", TINY, tmp_path / "a", comm=MPI.COMM_SELF).run()
    simulation("silo.yaml", short + ["time.end_time=0.02", "time.checkpoint_every=5"],
               tmp_path / "b", comm=MPI.COMM_SELF).run()
    resumed = simulation("silo.yaml", TINY, tmp_path / "b", comm=MPI.COMM_SELF, resume=True).run()
    assert abs(resumed["outflow_area"] - whole["outflow_area"]) < 1e-9 * whole["outflow_area"]
    assert abs(resumed["discharge_steady"] - whole["discharge_steady"]) < 1e-6 * whole["discharge_steady"]
    assert abs(resumed["area_drift"]) < 1e-9
