"""XDMFTimeSeries: per-step XDMF/H5 pairs plus an atomically rewritten master.

Serial:  .venv/bin/python -m pytest tests/system/test_xdmf.py -q
MPI:     mpirun -n 2 .venv/bin/python -m pytest -m mpi tests/system/test_xdmf.py -q
The ParaView checks run tests/pv_read_xdmf.py under pvpython (skipped only when pvpython
is not on PATH).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.io.xdmf import XDMFTimeSeries
from tests.helpers import paraview_skip_reason, paraview_summaries

NAMES = ("velocity", "pressure", "strain_rate")
TIMES = [0.1, 0.25, 0.4, 0.55]  # three moving steps, then one after a remesh
N_FIRST = (4, 2)  # cells per direction: 2*4*2 = 16 triangles
N_REMESH = (6, 3)  # 36 triangles


# ----------------------------------------------------------------------------- helpers
def rectangle(comm, n):
    return compat.create_rectangle(comm, (0.0, 0.0), (2.0, 1.0), n)


def output_functions(mesh, t):
    """P1 vector velocity, P1 scalar pressure and DG0 strain_rate, all depending on t."""
    u = fem.Function(compat.vector_space(mesh, 1), name="velocity")
    p = fem.Function(compat.scalar_space(mesh, 1), name="pressure")
    s = fem.Function(compat.scalar_space(mesh, 0, "DG"), name="strain_rate")
    u.interpolate(lambda x: np.vstack([t + 0.0 * x[0], -t * x[0]]))
    p.interpolate(lambda x: t * (1.0 - x[1]))
    s.x.array[:] = 10.0 * t
    return [u, p, s]


def write_series(directory, comm, on_step=None):
    """Write TIMES: 3 steps on a moving mesh, then 1 on a finer (remeshed) mesh."""
    series = XDMFTimeSeries(Path(directory), comm)
    mesh = rectangle(comm, N_FIRST)
    for k, t in enumerate(TIMES[:3]):
        series.write(t, mesh, output_functions(mesh, t))
        if on_step is not None:
            on_step(k)
        mesh.geometry.x[:, 1] *= 1.5  # ALE move: stretch vertically, in place
    remeshed = rectangle(comm, N_REMESH)
    series.write(TIMES[3], remeshed, output_functions(remeshed, TIMES[3]))
    return series


def master_grids(master):
    root = ET.parse(master).getroot()
    collections = root.findall("Domain/Grid")
    assert len(collections) == 1
    assert collections[0].get("GridType") == "Collection"
    assert collections[0].get("CollectionType") == "Temporal"
    return collections[0].findall("Grid")


def check_master(master, times, last_cells):
    """The master parses, lists `times`, each grid flattened and pointing at live H5 data."""
    grids = master_grids(master)
    assert [float(g.find("Time").get("Value")) for g in grids] == times
    for grid in grids:
        assert grid.get("GridType") == "Uniform"
        assert not any("include" in el.tag for el in grid.iter())  # no xi:include left
        assert grid.find("Topology") is not None and grid.find("Geometry") is not None
        attrs = {a.get("Name"): a.get("Center") for a in grid.findall("Attribute")}
        assert attrs == {"velocity": "Node", "pressure": "Node", "strain_rate": "Cell"}
        for item in grid.iter("DataItem"):
            fname, h5path = item.text.strip().split(":")
            assert not os.path.isabs(fname) and fname.startswith("fields/step_")
            with h5py.File(master.parent / fname, "r") as f:
                shape = f[h5path].shape
                assert " ".join(map(str, shape)) == item.get("Dimensions")
                assert int(item.get("Precision")) == f[h5path].dtype.itemsize
    n_cells = int(grids[-1].find("Topology").get("NumberOfElements"))
    assert n_cells == last_cells
    return grids


def check_paraview_full(summary):
    assert summary["times"] == pytest.approx(TIMES, rel=0, abs=1e-12)
    for name in ("velocity", "pressure"):
        assert name in summary["point_arrays"]
    assert "strain_rate" in summary["cell_arrays"]
    first, last = summary["first"], summary["last"]
    for snap in summary["snapshots"]:
        assert {"velocity", "pressure"} <= set(snap["point_arrays"])
        assert "strain_rate" in snap["cell_arrays"]
        # values belong to their own time (read back in double precision)
        assert snap["ranges"]["strain_rate"] == pytest.approx([10 * snap["time"]] * 2)
    # the moving mesh: each step 1.5x taller than the one before
    heights = [s["bounds"][3] for s in summary["snapshots"][:3]]
    assert heights == pytest.approx([1.0, 1.5, 2.25])
    # remeshed last step: different mesh, the cell/point counts that were written
    assert first["num_cells"] == 2 * N_FIRST[0] * N_FIRST[1]
    assert last["num_cells"] == 2 * N_REMESH[0] * N_REMESH[1]
    assert last["num_points"] == (N_REMESH[0] + 1) * (N_REMESH[1] + 1)
    assert first["first_point"] != last["first_point"]


# ----------------------------------------------------------------------------- serial tests
@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The full series, plus a copy of the run directory taken right after step 2 of 3
    (a run killed there)."""
    comm = MPI.COMM_SELF
    root = tmp_path_factory.mktemp("xdmf")
    run, killed = root / "run", root / "killed"

    def snapshot_after(k):
        if k == 1:
            shutil.copytree(run, killed)

    series = write_series(run, comm, on_step=snapshot_after)
    return series, run, killed


def test_master_is_flattened_and_relative(written):
    series, run, _ = written
    assert series.steps == [(k, t) for k, t in enumerate(TIMES)]
    assert not (run / "solution.xdmf.tmp").exists()
    check_master(run / "solution.xdmf", TIMES, 2 * N_REMESH[0] * N_REMESH[1])
    for k in range(len(TIMES)):
        assert series.step_path(k).exists() and series.step_path(k).with_suffix(".h5").exists()


def test_killed_copy_is_valid_and_paraview_reads_both(written):
    _, run, killed = written
    check_master(killed / "solution.xdmf", TIMES[:2], 2 * N_FIRST[0] * N_FIRST[1])
    full, partial = paraview_summaries(run / "solution.xdmf", killed / "solution.xdmf")
    keys = ("times", "point_arrays", "cell_arrays", "first", "last")
    print("pvpython summary:", json.dumps({k: full[k] for k in keys}))
    check_paraview_full(full)
    assert partial["times"] == pytest.approx(TIMES[:2], rel=0, abs=1e-12)
    assert partial["last"]["bounds"][3] == pytest.approx(1.5)
    assert {"velocity", "pressure"} <= set(partial["point_arrays"])
    assert "strain_rate" in partial["cell_arrays"]


def test_truncate_after_resume_and_continue(tmp_path):
    comm = MPI.COMM_SELF
    write_series(tmp_path, comm)
    # restart from a checkpoint at t = 0.25: a new writer reads the master (resume)
    series = XDMFTimeSeries(tmp_path, comm)
    assert [t for _, t in series.steps] == TIMES
    series.truncate_after(0.25)
    assert series.steps == [(0, 0.1), (1, 0.25)]
    fields = sorted(p.name for p in (tmp_path / "fields").iterdir())
    assert fields == ["step_000000.h5", "step_000000.xdmf", "step_000001.h5", "step_000001.xdmf"]
    check_master(tmp_path / "solution.xdmf", [0.1, 0.25], 2 * N_FIRST[0] * N_FIRST[1])

    # continue with different output times; a time not after the last one is refused
    mesh = rectangle(comm, N_REMESH)
    with pytest.raises(ValueError, match="not after"):
        series.write(0.25, mesh, output_functions(mesh, 0.25))
    for t in (0.3, 0.45):
        path = series.write(t, mesh, output_functions(mesh, t))
    assert path == tmp_path / "fields" / "step_000003.xdmf"
    assert series.steps == [(0, 0.1), (1, 0.25), (2, 0.3), (3, 0.45)]
    grids = check_master(tmp_path / "solution.xdmf", [0.1, 0.25, 0.3, 0.45], 36)
    assert len({g.get("Name") for g in grids}) == len(grids)
    items = [item.text for g in grids for item in g.iter("DataItem")]
    assert len(set(items)) == len(items)  # no two grids share a dataset
    # a third writer sees the same steps
    assert XDMFTimeSeries(tmp_path, comm).steps == series.steps


def test_resume_drops_orphan_step_of_a_killed_write(tmp_path):
    """Killed after DOLFINx wrote step 2 but before the master listed it."""
    comm = MPI.COMM_SELF
    series = XDMFTimeSeries(tmp_path, comm)
    mesh = rectangle(comm, N_FIRST)
    for t in (0.1, 0.2):
        series.write(t, mesh, output_functions(mesh, t))
    master_before = (tmp_path / "solution.xdmf").read_bytes()
    compat.write_xdmf_step(comm, str(tmp_path / "fields" / "step_000002.xdmf"), mesh,
                           output_functions(mesh, 0.3), 0.3)
    (tmp_path / "solution.xdmf.tmp").write_text("<Xdmf")  # half-written master
    resumed = XDMFTimeSeries(tmp_path, comm)
    assert (tmp_path / "solution.xdmf").read_bytes() == master_before
    assert resumed.steps == [(0, 0.1), (1, 0.2)]
    assert not (tmp_path / "fields" / "step_000002.h5").exists()
    assert not (tmp_path / "solution.xdmf.tmp").exists()
    resumed.write(0.3, mesh, output_functions(mesh, 0.3))
    assert resumed.steps[-1] == (2, 0.3)
    check_master(tmp_path / "solution.xdmf", [0.1, 0.2, 0.3], 16)


def test_truncate_to_nothing_then_restart(tmp_path):
    comm = MPI.COMM_SELF
    series = XDMFTimeSeries(tmp_path, comm)
    mesh = rectangle(comm, N_FIRST)
    series.write(1.0, mesh, output_functions(mesh, 1.0))
    series.truncate_after(0.0)
    assert series.steps == [] and not (tmp_path / "solution.xdmf").exists()
    assert list((tmp_path / "fields").iterdir()) == []
    series.write(0.5, mesh, output_functions(mesh, 0.5))
    assert series.steps == [(0, 0.5)]


def test_rejects_bad_functions(tmp_path):
    comm = MPI.COMM_SELF
    series = XDMFTimeSeries(tmp_path, comm)
    mesh = rectangle(comm, N_FIRST)
    u, p, s = output_functions(mesh, 0.0)
    p2 = fem.Function(compat.vector_space(mesh, 2), name="velocity_p2")
    dg1 = fem.Function(compat.scalar_space(mesh, 1, "DG"), name="dg1")
    for bad in (p2, dg1):
        with pytest.raises(ValueError, match="P1 .* or DG0"):
            series.write(0.0, mesh, [u, bad])
    twin = fem.Function(compat.scalar_space(mesh, 1), name="pressure")
    with pytest.raises(ValueError, match="unique names"):
        series.write(0.0, mesh, [u, p, twin])
    other = rectangle(comm, N_REMESH)
    with pytest.raises(ValueError, match="not defined on the mesh"):
        series.write(0.0, other, [u])
    assert series.steps == [] and not (tmp_path / "solution.xdmf").exists()
    assert list((tmp_path / "fields").iterdir()) == []


# ----------------------------------------------------------------------------- MPI test
@pytest.mark.mpi
def test_mpi_ranks_write_one_series():
    """Under mpirun -n 2 every rank writes its part; rank 0 checks master + ParaView.
    Also passes serially (one rank)."""
    comm = MPI.COMM_WORLD
    directory = comm.bcast(tempfile.mkdtemp(prefix="dpc_xdmf_mpi_") if comm.rank == 0 else None)
    try:
        series = write_series(directory, comm)
        assert series.steps == [(k, t) for k, t in enumerate(TIMES)]  # same on every rank
        error = None
        skip = paraview_skip_reason()   # the same on every rank: skip together (pip path)
        if comm.rank == 0:
            try:
                master = Path(directory) / "solution.xdmf"
                check_master(master, TIMES, 2 * N_REMESH[0] * N_REMESH[1])
                assert XDMFTimeSeries(Path(directory), MPI.COMM_SELF).steps == series.steps
                if skip is None:
                    (summary,) = paraview_summaries(master)
                    print("rank 0 pvpython times:", summary["times"],
                          summary["last"]["num_cells"])
                    check_paraview_full(summary)
            except BaseException as exc:  # report on every rank instead of hanging
                error = exc
        error = comm.bcast(error, root=0)
        if error is not None:
            raise error
        if skip is not None:
            pytest.skip(skip)
    finally:
        comm.Barrier()
        if comm.rank == 0:
            shutil.rmtree(directory, ignore_errors=True)
