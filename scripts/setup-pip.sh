#!/usr/bin/env bash
# The pip path of ./scripts/setup.sh (called as `./scripts/setup.sh --pip`): no apt, no root.
#   1. checks: Python >= 3.12 (${PYTHON:-python3}), Linux x86_64 with glibc >= 2.34 (the
#      platform of the dolfinx-solver-real wheel), a C compiler and the Python headers
#      (FFCx compiles every form with them);
#   2. a .venv at the repository root from that Python (no system site packages);
#   3. this package, editable, with the `test` and `wheels` extras: DOLFINx 0.11 with
#      real PETSc (dolfinx-solver-real), MPICH, mpi4py, basix/ffcx/ufl, gmsh, h5py, numpy,
#      scipy, all from PyPI;
#   4. a .pth file that makes every Python of the venv import the wheel's MPI before DOLFINx
#      (dpcollapse/wheel_mpi.py);
#   5. an import check of DOLFINx under the wheel's MPI and of gmsh (its wheel needs the
#      system's X11/GLU libraries).
# Each failed check prints one line naming what is missing and exits 2.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

fail() { echo "setup --pip: $*" >&2; exit 2; }

python="${PYTHON:-python3}"
command -v "$python" >/dev/null 2>&1 || fail "no $python on PATH: install Python >= 3.12 (or set PYTHON=/path/to/python3.12)"
"$python" -c 'import sys; sys.exit(sys.version_info < (3, 12))' ||
  fail "Python $("$python" -c 'import platform; print(platform.python_version())') is too old: the DOLFINx wheel needs Python >= 3.12 (set PYTHON=/path/to/python3.12), or take the apt path (./scripts/setup.sh)"
platform_ok="$("$python" -c '
import platform
libc, version = platform.libc_ver()
parts = tuple(int(p) for p in version.split(".")[:2]) if version else (0, 0)
ok = platform.system() == "Linux" and platform.machine() == "x86_64" and libc == "glibc" and parts >= (2, 34)
print("ok" if ok else " ".join([platform.system(), platform.machine(), libc or "no glibc", version]))')"
[ "$platform_ok" = ok ] ||
  fail "no DOLFINx wheel for this platform ($platform_ok): the wheel is Linux x86_64 with glibc >= 2.34; use conda-forge, Spack or a container (docs/versions.md)"
cc="${CC:-cc}"
command -v "$cc" >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 ||
  fail "no C compiler (cc or gcc): FFCx compiles the forms; install gcc (Debian/Ubuntu: gcc, RHEL: gcc)"
"$python" -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' ||
  fail "no Python.h for $python: FFCx compiles the forms against it; install the Python headers (Debian/Ubuntu: python3-dev, RHEL: python3-devel)"

if [ -x .venv/bin/python ] && [ ! -f .venv/.dpcollapse-pip ]; then
  fail ".venv was made by the apt path; remove it (rm -rf .venv) to take the pip path"
fi
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv from $python (pip path)"
  "$python" -m venv .venv || fail "$python -m venv failed: install the venv module (Debian/Ubuntu: python3-venv)"
  touch .venv/.dpcollapse-pip
fi

# Reinstall only when pyproject.toml changed since the last successful install.
stamp=.venv/.dpcollapse-installed
want="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ] || [ ! -x .venv/bin/dpcollapse ]; then
  echo "setup: installing dpcollapse (editable) with DOLFINx 0.11 and MPICH from PyPI wheels"
  .venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip
  .venv/bin/python -m pip install -q --disable-pip-version-check --prefer-binary -e ".[test,wheels]"
  echo "$want" > "$stamp"
fi
# Every Python of the venv loads the wheel's MPI before DOLFINx (dpcollapse/wheel_mpi.py), so
# that a script or test that imports dolfinx first works as in any other DOLFINx install.
site="$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
echo "import dpcollapse.wheel_mpi as m; m.install()" > "$site/dpcollapse_wheel_mpi.pth"

# DOLFINx, its MPI and gmsh load; one line on failure instead of a traceback.
check="$(.venv/bin/python -c '
import dolfinx
from petsc4py import PETSc
assert PETSc.ScalarType.__name__ == "float64", PETSc.ScalarType
print("dolfinx", dolfinx.__version__)' 2>&1 | tail -1)" ||
  fail "DOLFINx from the wheel does not import: $check"
gmsh_check="$(.venv/bin/python -c 'import gmsh' 2>&1 | tail -1)" ||
  fail "gmsh does not import ($gmsh_check): its wheel needs the system libraries libGL, libGLU, libXcursor, libXft, libXinerama (Debian/Ubuntu: libgl1 libglu1-mesa libxcursor1 libxft2 libxinerama1; RHEL: mesa-libGL mesa-libGLU libXcursor libXft libXinerama)"
echo "setup: pip path ready ($check, MPI: .venv/bin/mpiexec)"
