"""The erodible-bed scene (seed 000, case II) on the two-phase model, shortened on a coarse
box: the mass collapses onto the layer ahead of its toe and sets part of it in motion, c and
the layer's own fraction c_L are conserved, c_L is written and resumes from a checkpoint,
and 2 MPI ranks agree with one."""

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import simulation

CONFIG = "erodible_eulerian.yaml"
#: 2 cm cells on the 1.0 m × 0.30 m box (50 × 15 squares, 1500 triangles)
SMALL = ["geometry.mesh_size=0.02", "time.output_every=20", "time.checkpoint_every=50"]
TOE = 0.297


def test_mass_reaches_the_layer_ahead_of_its_toe(tmp_path):
    """To t = 0.16 s at 2 cm: the mass front (granular cells above 2 h_e) passes the toe by
    more than a cell (measured 0.32 m from t = 0.14 s with the compression along the interface
    normal, from 0.12 s with `facet`), so the flank has come down onto the layer; part of the
    layer is set in motion but not all of it; c and c_L keep their areas (drift < 1e-10), c_L
    its bounds, and the run wrote "layer_fraction"."""
    summary = simulation(CONFIG, SMALL + ["time.end_time=0.16"], tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time" and summary["model"] == "two_phase"
    assert summary["front"] > TOE + 0.02
    assert abs(summary["area_drift"]) < 1e-10
    columns = read_diagnostics(tmp_path / "diagnostics.csv")
    layer = np.asarray(columns["layer_area"])
    assert np.abs(layer / layer[0] - 1).max() < 1e-10
    assert 0.0 < max(columns["layer_moving"]) < 0.9
    assert columns["layer_outside"][0] < columns["layer_outside"][-1]
    text = (tmp_path / "solution.xdmf").read_text()
    for name in ("volume_fraction", "layer_fraction"):
        assert f'Name="{name}"' in text, name


def test_resume_carries_the_layer(tmp_path):
    """Stopped at 0.03 s and resumed to 0.05 s: the layer's measures of the whole run."""
    whole = simulation(CONFIG, SMALL + ["time.end_time=0.05"], tmp_path / "a", comm=MPI.COMM_SELF).run()
    simulation(CONFIG, SMALL + ["time.end_time=0.03", "time.checkpoint_every=10"], tmp_path / "b",
               comm=MPI.COMM_SELF).run()
    resumed = simulation(CONFIG, SMALL + ["time.end_time=0.05"], tmp_path / "b", comm=MPI.COMM_SELF,
                         resume=True).run()
    assert resumed["steps"] == whole["steps"]
    for key in ("layer_area", "layer_moving", "layer_outside", "area"):
        assert resumed[key] == pytest.approx(whole[key], rel=1e-9, abs=1e-14), key


@pytest.mark.mpi
def test_two_ranks_agree_with_one(shared_tmp, comm, tmp_path):
    """The layer's measures (sums over the owned cells) under 2 ranks are the serial ones."""
    over = SMALL + ["time.end_time=0.03"]
    parallel = simulation(CONFIG, over, shared_tmp / "par", comm=comm).run()
    serial = simulation(CONFIG, over, tmp_path / f"ser{comm.rank}", comm=MPI.COMM_SELF).run()
    assert parallel["steps"] == serial["steps"]
    for key in ("layer_area", "layer_outside", "area"):
        assert parallel[key] == pytest.approx(serial[key], rel=1e-7, abs=1e-12), key
    assert parallel["layer_moving"] == pytest.approx(serial["layer_moving"], abs=1e-6)
