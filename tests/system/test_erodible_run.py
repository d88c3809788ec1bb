"""Short erodible-bed collapses (seed 000 case II): the fold where the moving mass meets the
static layer, seed 000's local surface tension that carries the run past it, the material
regions in the output, serial against 2 ranks (issue 14)."""

import re

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.errors import MeshError
from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import paraview_summaries, simulation

#: 2 cm cells; γ̄0 = ρ g h² ≈ 6 N/m at h = 2 cm (configs/erodible.yaml: 1.5 N/m at 1 cm).
COARSE = ["geometry.mesh_size=0.02", "time.output_every=40", "time.checkpoint_every=1000"]
GAMMA = "boundary.surface_tension=6.0"
#: The toe of the mass on the layer at t = 0 [m] and the layer's top [m].
TOE, LAYER_TOP = 0.297, 0.005


def test_the_free_surface_folds_over_the_layer_without_surface_tension(tmp_path):
    """Without surface tension and without the boundary surgery (nor the area put back: the
    config before issue 49) the flank rolls over the static layer ahead of the toe and the
    free surface crosses the layer's top (measured:
    t = 0.120 s, x = 0.32 m): exit 4, naming where; with γ̄0 = ρ g h² the same run passes
    that time with a simple boundary, the area kept, the layer and the mass exported as two
    regions."""
    with pytest.raises(MeshError, match="intersects itself at") as failure:
        simulation("erodible.yaml", COARSE + ["boundary.surface_tension=0", "time.end_time=0.3",
                                              "numerics.remesh_surgery=false",
                                              "numerics.remesh_conserve_area=false",
                                              "numerics.step_conserve_area=false"],
                   tmp_path / "plain", comm=MPI.COMM_SELF).run()
    message = str(failure.value)
    t_fold = float(re.search(r"after t = ([0-9.]+) s", message).group(1))
    x, y = map(float, re.search(r"at \(([0-9.]+), ([0-9.]+)\) m", message).groups())
    assert 0.05 < t_fold < 0.2
    assert TOE < x < TOE + 0.1 and abs(y - LAYER_TOP) < 0.005
    assert "edges tagged 3 and 3" in message          # two free-surface edges

    run = tmp_path / "tension"
    summary = simulation("erodible.yaml", COARSE + [GAMMA, f"time.end_time={t_fold + 0.01:.3f}"],
                         run, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time" and summary["remeshes"] >= 1
    assert abs(summary["area_drift"]) < 1e-3
    d = read_diagnostics(run / "diagnostics.csv")
    assert d["front"][-1] > TOE + 0.01
    (pv,) = paraview_summaries(run / "solution.xdmf")
    assert {"material_region", "strain_rate"} <= set(pv["cell_arrays"])
    assert "surface_tension" in pv["point_arrays"]
    assert pv["last"]["ranges"]["material_region"] == [10.0, 11.0]


def test_the_nose_merges_into_the_layer_by_surgery(tmp_path):
    """The same fold without surface tension, with the boundary surgery (on by default): at
    the remeshes the nose that crossed the layer's top is merged into the contact (the
    overlap taken from the mass, the layer kept), the run goes on past the fold (exit 4
    without the surgery, above) to t = 0.2 s; each surgery changes the layer by < 1e-9 of
    its area and, after the put-back, the mass by < 1e-9 of its own; the area drift of the
    run < 1e-3; the surgeries counted in diagnostics.csv and listed in run.json."""
    import json

    run = tmp_path / "surgery"
    summary = simulation("erodible.yaml", COARSE + ["boundary.surface_tension=0",
                                                    "time.end_time=0.2"],
                         run, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time" and summary["surgeries"] >= 1
    assert abs(summary["area_drift"]) < 1e-3
    events = json.loads((run / "run.json").read_text())["summary"]["surgery_events"]
    assert len(events) == summary["surgeries"]
    for e in events:
        layer, mass = e["regions"]["erodible_layer"], e["regions"]["granular_mass"]
        assert abs(layer["surgery_change"]) < 1e-9 * layer["area_before"]
        assert abs(layer["change"]) < 1e-9 * layer["area_before"]
        assert abs(mass["change"]) < 1e-9 * mass["area_before"]
    assert any(e["regions"]["granular_mass"]["surgery_change"] < 0 for e in events)
    d = read_diagnostics(run / "diagnostics.csv")
    assert d["surgeries"][-1] == summary["surgeries"] and d["t"][-1] >= 0.2 - 1e-9
    assert d["front"][-1] > TOE + 0.05


@pytest.mark.mpi
def test_erodible_run_serial_and_parallel_agree(shared_tmp, comm):
    """With the surface tension on (its polyline gathered across the ranks), the first steps
    on 2 ranks give the serial diagnostics."""
    over = COARSE + [GAMMA, "time.end_time=0.03"]
    simulation("erodible.yaml", over, shared_tmp / "parallel", comm=comm).run()
    if comm.rank == 0:
        simulation("erodible.yaml", over, shared_tmp / "serial", comm=MPI.COMM_SELF).run()
        par = read_diagnostics(shared_tmp / "parallel" / "diagnostics.csv")
        ser = read_diagnostics(shared_tmp / "serial" / "diagnostics.csv")
        assert par["iterations"] == ser["iterations"]
        for key in ("t", "front", "kinetic_energy", "area", "max_speed"):
            np.testing.assert_allclose(par[key], ser[key], rtol=1e-6, atol=1e-12, err_msg=key)


@pytest.mark.parametrize("method", ["regularized", "augmented_lagrangian"])
def test_both_models_carry_the_surface_tension(tmp_path, method):
    """A few steps of either model with the tension on: the right-hand side has the term,
    and its P1 field γ is, at the surface's nodes, γ0_i C_i of the current surface."""
    from dpcollapse.geometry.free_surface import surface_tension_nodes
    from dpcollapse.geometry.mesher import SURFACE

    sim = simulation("erodible.yaml", COARSE + [GAMMA, "time.end_time=0.005",
                                                f"numerics.method={method}"],
                     tmp_path, comm=MPI.COMM_SELF)
    summary = sim.run()
    assert summary["status"] == "end_time"
    flow = sim.disc.flow
    assert list(flow.rhs_terms)[-1] == "surface_tension"
    flow.update_surface_tension()
    points, gamma = surface_tension_nodes(sim.disc.tagged, [SURFACE], 6.0, 4.0)
    x = flow.surface_gamma.function_space.tabulate_dof_coordinates()[:, :2]
    peak = int(np.argmax(np.abs(gamma)))
    at_peak = np.flatnonzero(np.linalg.norm(x - points[peak], axis=1) < 1e-12)
    assert gamma[peak] != 0 and flow.surface_gamma.x.array[at_peak] == pytest.approx(gamma[peak])
    assert np.abs(flow.surface_gamma.x.array).max() == pytest.approx(abs(gamma[peak]))
