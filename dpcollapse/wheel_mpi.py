"""MPI before DOLFINx on the pip path (the ``dolfinx-solver-real`` wheel).

The wheel's compiled DOLFINx and petsc4py link ``libmpi.so.12`` by name only; it is the
PyPI ``mpich`` wheel's (``<venv>/lib``), which ``mpi4py.MPI`` finds and loads. So
``dolfinx_solver`` (which imports ``mpi4py.MPI`` and checks that no other petsc4py shadows
the wheel's) must be imported before ``dolfinx`` or ``petsc4py``; otherwise the import
fails with "libmpi.so.12: cannot open shared object file".

:func:`install` puts a finder first on ``sys.meta_path`` that does this on the first
import of ``dolfinx``, ``petsc4py`` or ``slepc4py``, and nothing else: a serial command
that never touches DOLFINx (``dpcollapse check``, ``sweep``) still never initializes MPI.
Where ``dolfinx_solver`` is not installed (the apt path) it does nothing.
``scripts/setup.sh --pip`` also calls it from a ``.pth`` file, for every Python of the venv.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys

#: Top-level modules of the wheel whose compiled parts need the MPI library loaded first.
_BINDINGS = frozenset({"dolfinx", "petsc4py", "slepc4py"})


class _MPIFirst(importlib.abc.MetaPathFinder):
    """Imports ``dolfinx_solver`` just before the first of ``_BINDINGS``, then leaves."""

    def find_spec(self, fullname, path, target=None):
        if fullname in _BINDINGS:
            uninstall()
            import dolfinx_solver  # noqa: F401  (loads mpi4py.MPI, checks petsc4py)
        return None   # the ordinary finders import the module itself


def install() -> None:
    """Put the finder in place when the wheel is installed and DOLFINx not yet imported."""
    if any(isinstance(f, _MPIFirst) for f in sys.meta_path):
        return
    if "dolfinx_solver" in sys.modules or _BINDINGS.intersection(sys.modules):
        return
    if importlib.util.find_spec("dolfinx_solver") is None:
        return
    sys.meta_path.insert(0, _MPIFirst())


def uninstall() -> None:
    sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, _MPIFirst)]
