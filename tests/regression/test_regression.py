"""The current code against stored values of the code before the redesign (issue 12).

``reference.json`` was written by ``tests/regression/record.py`` from runs of commit
d1fd579 (the ``commit`` field of each case). Steps, remeshes and fixed-point iterations
must be equal; front and maximum height within 1e-6 m; kinetic energy within 1e-6 relative
(or 1e-9 J/m, for a mass at rest); the largest speed within 1e-6 m/s.

Recorded (old code, serial): ``PYTHONPATH=<checkout of d1fd579> python
tests/regression/record.py --out tests/regression/reference.json``; the full rigid run was
recorded twice with identical results (935 steps, 18 remeshes, front 0.666368067829625 m,
maximum height 0.21001527625351757 m at t = 0.9327 s).

Those values are DOLFINx 0.5.2's. The same code on 0.9 and 0.11 differs by round-off that
this problem amplifies (docs/benchmarks/2026-12-01-dolfinx-versions.md: the deposit within
0.26 mm, a remesh or two more or fewer), so each supported version has its own stored
values, compared just as strictly: ``reference-0.9.json`` and ``reference-0.11.json`` were
recorded by the same command in Debian 13 and sid chroots (``scripts/chroot-test.sh trixie
--run '.venv/bin/python tests/regression/record.py --out …'``) from commit 700ca9c, whose
0.5.2 values are those of d1fd579 exactly.
"""

import json
from pathlib import Path

import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.io.diagnostics import read_diagnostics
from tests.regression.record import CASES, run_case

_FILES = {(0, 5): "reference.json", (0, 9): "reference-0.9.json", (0, 11): "reference-0.11.json",
          (0, 11, "wheel"): "reference-0.11-wheel.json"}
_KEY = tuple(compat.DOLFINX_VERSION[:2]) + (("wheel",) if compat.DOLFINX_BUILD == "wheel" else ())
_FILE = _FILES.get(_KEY)
pytestmark = pytest.mark.skipif(
    _FILE is None, reason=f"no stored values for DOLFINx {compat.DOLFINX_VERSION_TEXT}")
REFERENCE = json.loads((Path(__file__).parent / _FILE).read_text()) if _FILE else {}


def _compare(got: dict, ref: dict) -> None:
    for key in ("steps", "remeshes", "flow_solves"):
        assert got[key] == ref[key], (key, got[key], ref[key])
    assert got["status"] == ref["status"]
    assert got["t"] == pytest.approx(ref["t"], abs=1e-12)
    for key in ("front", "max_height", "max_speed"):
        assert got[key] == pytest.approx(ref[key], abs=1e-6), key
    assert got["kinetic_energy"] == pytest.approx(ref["kinetic_energy"], rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("name", list(CASES))
def test_short_run_matches_stored_values(name, tmp_path):
    _compare(run_case(name, tmp_path, MPI.COMM_SELF), REFERENCE[name])


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["rigid_short", "plug_short"])
def test_short_run_on_all_ranks_matches_stored_values(name, shared_tmp, comm):
    """The serial reference holds on 2 ranks too (same steps and remeshes; 1e-6)."""
    _compare(run_case(name, shared_tmp, comm), REFERENCE[name])


@pytest.mark.slow
def test_full_rigid_run_matches_stored_values(tmp_path):
    """configs/rigid.yaml to rest (~90 s serial): same steps and remeshes, front and
    maximum height at rest within 1e-6 m."""
    got = run_case("rigid_full", tmp_path, MPI.COMM_SELF)
    _compare(got, REFERENCE["rigid_full"])
    # and what makes it a physical result (this test replaces tests/system/test_collapse.py's
    # test_full_rigid_case_reaches_rest, so that the 90 s run is done once)
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    assert got["status"] == "at_rest"
    assert abs(d["area"][-1] - d["area"][0]) <= 5e-3 * d["area"][0]
    assert min(d["min_detJ"]) > 0
    assert got["kinetic_energy"] < 1e-6
    assert 0.55 < got["front"] < 0.80  # runout of seed 000's deposit scale (~0.67 m here)
    assert 0.6 < got["t"] < 1.5
