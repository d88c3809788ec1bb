"""The column collapse on a no-slip bed (configs/column_a0.5.yaml, coarse): the toe
overturns, its nose lands on the bed and the folded front is carried through remeshing."""

import json

import numpy as np
from mpi4py import MPI

from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import simulation


def test_no_slip_column_carries_the_fold(tmp_path):
    """2 cm mesh, to t = 0.25 s (past the landings of the overturning nose and the film that made the
    unrepaired run fail at t ≈ 0.13–0.16 s)."""
    summary = simulation("column_a0.5.yaml", ["geometry.mesh_size=0.02", "time.end_time=0.25"],
                         tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    assert summary["landings"] > 0                      # the nose came down on the bed
    assert summary["remeshes"] > 0
    assert summary["min_detJ"] > 0                      # no inverted cell
    # each move's and each remesh's area change put back (numerics.step_conserve_area,
    # remesh_conserve_area): measured -3.4e-14; -1.9e-3 before step_conserve_area
    assert abs(summary["area_drift"]) < 1e-9
    # the thickness front is behind (or at) the mass front and moved forward
    assert 0.1 < summary["thick_front"] <= summary["front"]
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    assert np.all(np.diff(d["landings"]) >= 0) and d["landings"][-1] == summary["landings"]
    assert json.loads((tmp_path / "run.json").read_text())["summary"]["thick_front"] == summary["thick_front"]
