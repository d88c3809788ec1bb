"""The version seam: every DOLFINx call that differs between 0.5, 0.9 and 0.11 lives in
``dpcollapse/compat.py``; the helpers behave the same on every version; an error on one
MPI rank ends the whole job."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from tests.helpers import OVERSUBSCRIBE, clean_env

ROOT = Path(__file__).resolve().parents[2]

#: Names whose meaning or existence differs between the supported DOLFINx versions.
VERSION_SPECIFIC = {
    r"\.vector\b(?!_)": "Function.vector (gone in 0.9: compat.petsc_vec)",
    r"\b(Vector|Tensor|Mixed|Finite)Element\b": "ufl elements (basix.ufl from 0.7: compat spaces)",
    r"\b(Vector|Tensor)?FunctionSpace\(": "space constructors (fem.functionspace from 0.7)",
    r"\.family\(\)|\.degree\(\)": "ufl element inspection (compat.element_info)",
    r"(?<!compat)\.create_rectangle\(|import create_rectangle": "create_rectangle's arguments",
    r"\bgmshio\b|dolfinx\.io\.gmsh\b": "gmsh import module (compat.gmsh_model_to_mesh)",
    r"\.sub\(\d\)\.collapse\(\)|\bS\.collapse\(\)": "space collapse dofs (compat.collapse)",
    r"fem_petsc\.create_(vector|matrix)\b": "PETSc vector/matrix creation (compat.create_*)",
    r"Expression\([^)]*\)\.eval\(": "Expression.eval signature (compat.eval_expression)",
    r"\binterpolation_points\b": "method or property (compat.interpolation_points)",
    r"BoundingBoxTree|compute_collisions\(|\bbb_tree\b": "bounding boxes (compat)",
    r"dolfinx\.cpp|\b_cpp\b|\._mesh\b|_cpp_object": "C++ layer (compat)",
    r"\.homogenize\(|\.backsubstitution\(|dolfinx_mpc\.cpp": "dolfinx_mpc (compat.mpc_*)",
    r"geometry\.dofmap|dofmap\.list|\bcreate_mesh\(|entities_to_geometry as": "maps (compat)",
    r"form_compiler_(params|options)|jit_(params|options)": "form options (renamed in 0.6)",
}


def _python_files():
    for base in ("dpcollapse", "tests", "scripts"):
        for path in sorted((ROOT / base).rglob("*.py")):
            if path.name in ("compat.py", "test_compat.py"):
                continue
            yield path


def test_version_specific_calls_live_in_compat():
    found = []
    for path in _python_files():
        for lineno, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            if code.lstrip().startswith(('"', "'")):
                continue          # docstring lines
            for pattern, what in VERSION_SPECIFIC.items():
                if re.search(pattern, code):
                    found.append(f"{path.relative_to(ROOT)}:{lineno}: {what}: {line.strip()}")
    assert not found, "version-specific DOLFINx calls outside compat.py:\n" + "\n".join(found)


def test_the_grep_catches_what_it_is_for():
    """The patterns do match the old-style calls (a grep that matches nothing proves nothing)."""
    samples = [
        "x = u.vector",
        "ufl.VectorElement('P', c, 2)",
        "el.family()",
        "dmesh.create_rectangle(comm, p, n)",
        "from dolfinx.mesh import create_rectangle",
        "from dolfinx.io import gmshio",
        "V, d = W.sub(0).collapse()",
        "fem_petsc.create_vector(L)",
        "fem.Expression(e, pts).eval(cells)",
        "V.element.interpolation_points()",
        "geometry.BoundingBoxTree(m, 2)",
        "mesh._mesh",
        "mpc.homogenize(x)",
        "mesh.geometry.dofmap",
        "fem.form(a, form_compiler_params={})",
    ]
    for sample in samples:
        assert any(re.search(p, sample) for p in VERSION_SPECIFIC), sample
    for fine in ["u.x.petsc_vec", "vector_space(mesh, 1)", "compat.collapse(W.sub(0))",
                 "velocity_vector = 1"]:
        assert not any(re.search(p, fine) for p in VERSION_SPECIFIC), fine


@pytest.fixture(scope="module")
def square():
    return compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 0.5), (1, 1))


def test_element_info_on_every_kind_of_space(square):
    W = compat.taylor_hood_space(square)
    cases = {
        "P1": (compat.scalar_space(square, 1), ("P", 1, False)),
        "P2 vector": (compat.vector_space(square, 2), ("P", 2, False)),
        "DG0": (compat.scalar_space(square, 0, "DG"), ("DG", 0, False)),
        "DG1": (compat.scalar_space(square, 1, "DG"), ("DG", 1, False)),
        "DG2 tensor": (compat.tensor_space(square, 2), ("DG", 2, False)),
        "velocity of Taylor–Hood": (W.sub(0), ("P", 2, False)),
        "pressure of Taylor–Hood": (W.sub(1), ("P", 1, False)),
    }
    for name, (V, expected) in cases.items():
        info = compat.element_info(V)
        assert (info.family, info.degree, info.mixed) == expected, name
    assert compat.element_info(W).mixed


def test_spaces_have_the_expected_sizes(square):
    # 2 triangles: 4 vertices, 5 edges
    assert compat.scalar_space(square, 1).dofmap.index_map.size_local == 4
    V = compat.vector_space(square, 2)
    assert V.dofmap.index_map.size_local * V.dofmap.index_map_bs == 2 * 9
    T = compat.tensor_space(square, 1)
    assert T.dofmap.index_map.size_local * T.dofmap.index_map_bs == 4 * 6
    W = compat.taylor_hood_space(square)
    Vc, vdofs = compat.collapse(W.sub(0))
    Qc, pdofs = compat.collapse(W.sub(1))
    assert vdofs.dtype == np.int32 and len(vdofs) == 18 and len(pdofs) == 4
    assert len(np.intersect1d(vdofs, pdofs)) == 0


def test_expression_eval_and_interpolation_points(square):
    import ufl

    S0 = compat.scalar_space(square, 0, "DG")
    assert compat.interpolation_points(S0).shape == (1, 2)
    expr = fem.Expression(ufl.SpatialCoordinate(square)[0], np.array([[1 / 3, 1 / 3]]))
    values = compat.eval_expression(expr, square, np.arange(2, dtype=np.int32)).ravel()
    assert sorted(np.round(values, 12)) == pytest.approx(sorted([1 / 3, 2 / 3]))


def test_petsc_vector_wraps_the_dofs(square):
    u = fem.Function(compat.scalar_space(square, 1))
    vec = compat.petsc_vec(u)
    vec.set(2.5)
    assert np.all(u.x.array == 2.5)


def test_entities_to_geometry_with_no_entities(square):
    """DOLFINx 0.9.0 kills the process on an empty list; the helper must not call it."""
    nodes = compat.entities_to_geometry(square, 1, np.zeros(0, dtype=np.int32))
    assert nodes.shape == (0, 2)
    square.topology.create_connectivity(1, 2)
    assert compat.entities_to_geometry(square, 1, np.arange(2, dtype=np.int32)).shape == (2, 2)


# ----------------------------------------------------------------------------- MPI endings
_SCRIPT = textwrap.dedent("""
    import sys
    from mpi4py import MPI
    from dpcollapse.parallel import end_together, start
    start()
    comm = MPI.COMM_WORLD
    if sys.argv[1] == "lone":
        if comm.rank == 1:
            end_together(3, "rank 1 failed alone")
            sys.exit(3)
        comm.barrier()          # without the abort, rank 0 would wait here forever
    else:
        end_together(3, "every rank failed")
        sys.exit(3)
""")


@pytest.mark.parametrize("mode", ["lone", "all"])
def test_an_error_on_one_rank_ends_the_whole_job(tmp_path, mode):
    mpirun = "mpirun"
    script = tmp_path / "fail.py"
    script.write_text(_SCRIPT)
    env = clean_env()
    env.update(OVERSUBSCRIBE, DPCOLLAPSE_MPI_GRACE="2",
               PYTHONPATH=str(ROOT) + os.pathsep + env.get("PYTHONPATH", ""))
    t0 = time.monotonic()
    proc = subprocess.run([mpirun, "-n", "2", sys.executable, str(script), mode],
                          capture_output=True, text=True, timeout=120, env=env)
    elapsed = time.monotonic() - t0
    assert proc.returncode == 3, proc.stderr[-2000:]
    assert elapsed < 60, elapsed
    if mode == "lone":
        assert "[rank 1] rank 1 failed alone" in proc.stderr
    else:
        assert "aborting the job" not in proc.stderr
