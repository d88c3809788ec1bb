"""The two-phase model in axisymmetric coordinates through the time loop (issue 52): the
cylindrical column's granular volume 2π∫ r c conserved to round-off, the cylindrical silo's
volume in the bin plus its outflow conserved, and two ranks giving the serial silo."""

import math

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.io.diagnostics import read_diagnostics
from tests.helpers import simulation

#: a cylinder r0 = 5.23 cm, H0 = 3.11 cm (cutting the 5 mm cells) in a 12 × 6 cm box, 30 ms
COLUMN = ["geometry.shape=column", "geometry.symmetry=axisymmetric", "geometry.height=0.0311",
          "geometry.base_length=0.0523", "geometry.mesh_size=0.005", "model.box_length=0.12",
          "model.box_height=0.06", "time.end_time=0.03", "time.output_every=100"]
#: the tiny silo of tests/system/test_silo_run.py as a cylinder: diameter 6 cm filled to
#: 5 cm, a 2 cm orifice at the axis, 5 mm cells (2.5 mm at the orifice), 40 ms
TINY_SILO = ["geometry.symmetry=axisymmetric", "geometry.width=0.06", "geometry.fill_height=0.05",
             "geometry.bin_height=0.06", "geometry.orifice_width=0.02", "geometry.mesh_size=0.005",
             "geometry.orifice_mesh_size=0.0025", "time.end_time=0.04", "time.output_every=100",
             "time.checkpoint_every=100"]


def _conserved(columns, *keys) -> tuple[float, float]:
    """(the initial total, the largest departure from it) of area + the ``keys`` columns."""
    total = np.asarray(columns["area"]) + sum(np.asarray(columns[k]) for k in keys)
    return float(total[0]), float(np.max(np.abs(total - total[0])))


def test_the_cylindrical_column_conserves_its_granular_volume(tmp_path):
    """``area`` is the body's volume π r0² H0 (radial overlap of the cut cells) and it plus
    what escaped stays there to round-off while the column spreads (measured: 2e-16)."""
    summary = simulation("column_eulerian_a0.5.yaml", COLUMN, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    columns = read_diagnostics(tmp_path / "diagnostics.csv")
    initial, drift = _conserved(columns, "escaped_area")
    assert initial == pytest.approx(math.pi * 0.0523**2 * 0.0311, rel=1e-12)
    assert drift < 1e-12 * initial
    assert summary["front"] > 0.0523          # it spreads past r0 (the cell edge beyond)


def test_planar_weighting_misses_the_cylinder_s_volume(tmp_path, monkeypatch):
    """Control: the same run with the initial c from the area overlaps (the planar
    fractions) starts with another volume than π r0² H0 (measured: +2.3e-3) — the test above
    sees the radial weighting."""
    from dpcollapse.models.two_phase import adapter, overlap

    monkeypatch.setattr(adapter, "union_fraction",
                        lambda tri, polygons, radial=False: overlap.union_fraction(tri, polygons))
    simulation("column_eulerian_a0.5.yaml", COLUMN + ["time.end_time=0.002"], tmp_path,
               comm=MPI.COMM_SELF).run()
    columns = read_diagnostics(tmp_path / "diagnostics.csv")
    initial, _ = _conserved(columns, "escaped_area")
    assert abs(initial / (math.pi * 0.0523**2 * 0.0311) - 1) > 1e-3


def test_the_cylindrical_silo_discharges_and_conserves_its_material(tmp_path):
    """The bin's volume plus the outflow is the fill π R² H to round-off; Q [kg/s] is the
    whole silo's (no factor 2 of the planar half bin): −Δm = Σ Q Δt."""
    summary = simulation("silo_axi.yaml", TINY_SILO, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time"
    columns = read_diagnostics(tmp_path / "diagnostics.csv")
    initial, drift = _conserved(columns, "outflow_area", "escaped_area")
    assert initial == pytest.approx(math.pi * 0.03**2 * 0.05, rel=1e-12)
    assert drift < 1e-12 * initial
    assert summary["outflow_area"] > 1e-6                 # m³ have left
    assert summary["discharge_steady"] > 0.05             # kg/s (measured 0.162)
    dt, q = np.asarray(columns["dt"]), np.asarray(columns["discharge_rate"])
    lost = columns["bin_mass"][0] - columns["bin_mass"][-1]
    assert abs(lost - float(np.sum(q[1:] * dt[1:]))) < 1e-9 * columns["bin_mass"][0]
    assert columns["bin_mass"][0] == pytest.approx(1550.0 * (initial - columns["outflow_area"][0]),
                                                   rel=1e-12)


@pytest.mark.mpi
def test_two_ranks_give_the_serial_cylindrical_silo(shared_tmp, comm, tmp_path):
    """The r-weighted facet fluxes across the partition: the same steps, outflow volume and
    steady Q as the serial run (to the LU's round-off)."""
    over = TINY_SILO + ["time.end_time=0.02"]
    parallel = simulation("silo_axi.yaml", over, shared_tmp / "par", comm=comm).run()
    serial = simulation("silo_axi.yaml", over, tmp_path / f"ser{comm.rank}", comm=MPI.COMM_SELF).run()
    assert parallel["steps"] == serial["steps"]
    for key in ("outflow_area", "discharge_steady", "area"):
        assert parallel[key] == pytest.approx(serial[key], rel=1e-7), key
    assert abs(parallel["area_drift"]) < 1e-12


def test_the_cylindrical_silo_resumes_with_its_volume(tmp_path):
    """Stopped at 20 ms and resumed to 40 ms: the outflow volume, the steady Q and the
    conservation are the uninterrupted run's (the checkpoint's c remapped onto the same mesh)."""
    short = [o for o in TINY_SILO if not o.startswith("time.end_time")]
    whole = simulation("silo_axi.yaml", TINY_SILO, tmp_path / "a", comm=MPI.COMM_SELF).run()
    simulation("silo_axi.yaml", short + ["time.end_time=0.02", "time.checkpoint_every=5"],
               tmp_path / "b", comm=MPI.COMM_SELF).run()
    resumed = simulation("silo_axi.yaml", TINY_SILO, tmp_path / "b", comm=MPI.COMM_SELF,
                         resume=True).run()
    assert abs(resumed["outflow_area"] - whole["outflow_area"]) < 1e-9 * whole["outflow_area"]
    assert resumed["discharge_steady"] == pytest.approx(whole["discharge_steady"], rel=1e-6)
    assert abs(resumed["area_drift"]) < 1e-9


def _unweighted(flow) -> list[str]:
    """The names of the flow's terms with an integral whose integrand has no r (x[0])."""
    from ufl import SpatialCoordinate
    from ufl.algorithms.analysis import extract_type

    forms = {**flow.terms, **flow.rhs_terms}
    return sorted(name for name, form in forms.items()
                  if any(not extract_type(i.integrand(), SpatialCoordinate) for i in form.integrals()))


@pytest.mark.parametrize("config", ["silo_axi.yaml", "hopper_axi.yaml"])
def test_every_term_of_the_two_phase_flow_carries_the_weight(config, tmp_path):
    """Every integral of every term (inertia, skew convection and its backflow side, the
    mixture's time derivative, the ambient traction, the walls' friction, Nitsche on the
    cone, grad-div) is weighted by 2πr; the planar silo (control) has unweighted terms."""
    over = TINY_SILO + ["model.grad_div=1.0"]
    axi = simulation(config, over, tmp_path / "axi", comm=MPI.COMM_SELF)
    names = set(axi.disc.flow.terms) | set(axi.disc.flow.rhs_terms)
    assert {"inertia", "convection", "previous_velocity", "grad_div", "orifice_ambient"} <= names
    assert _unweighted(axi.disc.flow) == []
    planar = simulation(config, over + ["geometry.symmetry=planar"], tmp_path / "planar",
                        comm=MPI.COMM_SELF)
    assert "inertia" in _unweighted(planar.disc.flow)
